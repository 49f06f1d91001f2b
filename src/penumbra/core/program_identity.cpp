#include "penumbra/core/program_identity.h"

#include <dlfcn.h>

#include <system_error>

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

}  // namespace penumbra
