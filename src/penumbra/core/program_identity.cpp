#include "penumbra/core/program_identity.h"

#include <dlfcn.h>
#include <unistd.h>

#include <fstream>
#include <system_error>
#include <thread>

#include <fmt/format.h>

namespace penumbra {

namespace fs = std::filesystem;
using nlohmann::json;

json file_identity(const fs::path& p) {
  std::error_code ec;
  auto size = fs::file_size(p, ec);
  if (ec) return json{{"path", p.string()}, {"missing", true}};
  auto mtime = fs::last_write_time(p, ec);
  long long ticks = ec ? 0 : static_cast<long long>(mtime.time_since_epoch().count());
  return json{{"path", p.string()}, {"size", size}, {"mtime", ticks}};
}

json program_identity() {
  Dl_info info{};
  if (::dladdr(reinterpret_cast<const void*>(&program_identity), &info) != 0 && info.dli_fname &&
      *info.dli_fname) {
    std::error_code ec;
    const fs::path self = fs::canonical(info.dli_fname, ec);
    if (!ec) return file_identity(self);
  }
  std::error_code ec;
  fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return json("unknown");
  return file_identity(exe);
}

std::string cpu_model() {
  std::ifstream f("/proc/cpuinfo");
  for (std::string line; std::getline(f, line);) {
    if (line.rfind("model name", 0) != 0) continue;
    const size_t colon = line.find(':');
    const size_t start = colon == std::string::npos ? colon : line.find_first_not_of(" \t", colon + 1);
    if (start != std::string::npos) return line.substr(start);
  }
  return "unknown";
}

std::string machine_identity() {
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  return fmt::format("{} / {} / {} logical cores", *host ? host : "unknown host", cpu_model(),
                     std::thread::hardware_concurrency());
}

}  // namespace penumbra
