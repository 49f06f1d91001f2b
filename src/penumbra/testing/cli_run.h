// Running the real `penumbra` binary from a test (app/cli_test.cpp, app/cli_gpu_test.cpp): its
// exit status and what it printed. Header-only; tests only (PENUMBRA_CLI is the test target's
// definition of the tool's path).
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>

namespace penumbra::testing {

struct CliRun {
  int exit_code;
  std::string out, err;
};

// The whole file, byte for byte ("" where it cannot be read: the test's assertion on the
// content then says what is missing).
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// `penumbra ARGS` with its output captured in files of `dir`; `env`: variable assignments for
// the run ("PATH=/x").
inline CliRun run_cli(const std::filesystem::path& dir, const std::string& args, const std::string& env = "") {
  const std::string out = (dir / "stdout.txt").string(), err = (dir / "stderr.txt").string();
  const std::string cmd = fmt::format("{} {} {} >{} 2>{}", env, PENUMBRA_CLI, args, out, err);
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
}

}  // namespace penumbra::testing
