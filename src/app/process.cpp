#include "app/process.h"

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include "penumbra/core/error.h"
#include "penumbra/core/interrupt.h"

namespace penumbra::app {

namespace fs = std::filesystem;

bool on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::stringstream folders(path ? path : "");
  for (std::string folder; std::getline(folders, folder, ':');) {
    const fs::path p = fs::path(folder.empty() ? "." : folder) / name;
    std::error_code ec;
    if (fs::is_regular_file(p, ec) && ::access(p.c_str(), X_OK) == 0) return true;
  }
  return false;
}

int run_program(const std::vector<std::string>& args, const ProgramOptions& options) {
  std::vector<std::string> copies = args;
  std::vector<char*> argv;
  for (std::string& a : copies) argv.push_back(a.data());
  argv.push_back(nullptr);
  // Our environment with options.environment's names replaced.
  std::vector<std::string> env_strings = options.environment;
  auto overridden = [&](const std::string& entry) {
    for (const std::string& e : options.environment)
      if (entry.compare(0, e.find('=') + 1, e, 0, e.find('=') + 1) == 0) return true;
    return false;
  };
  for (char** e = environ; *e; ++e)
    if (!overridden(*e)) env_strings.emplace_back(*e);
  std::vector<char*> env;
  for (std::string& e : env_strings) env.push_back(e.data());
  env.push_back(nullptr);
  // Standard input from /dev/null: a child reading the terminal would take the user's keys.
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  pid_t pid = 0;
  const int err = ::posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), env.data());
  posix_spawn_file_actions_destroy(&actions);
  if (err != 0) throw Error("cannot run {}: {}", args[0], std::strerror(err));
  int status = 0;
  for (int waited_ms = -1;;) {
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid || (r < 0 && errno != EINTR)) break;
    if (interrupted()) {
      if (waited_ms < 0 && options.interrupt_grace_ms > 0) ::kill(pid, SIGINT);
      waited_ms = std::max(waited_ms, 0);
      if (waited_ms >= options.interrupt_grace_ms) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, &status, 0);
        throw Interrupted();
      }
      waited_ms += 20;
    }
    ::usleep(20000);
  }
  if (interrupted()) throw Interrupted();  // it stopped on the signal: the run is interrupted
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

}  // namespace penumbra::app
