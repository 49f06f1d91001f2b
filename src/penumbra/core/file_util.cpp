#include "penumbra/core/file_util.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>

#include <unistd.h>

#include "penumbra/core/error.h"
#include "penumbra/core/interrupt.h"

namespace penumbra {

namespace fs = std::filesystem;

AtomicFile::AtomicFile(fs::path path)
    : path_(path.string()), tmp_(path_ + ".tmp-" + std::to_string(::getpid())) {
  register_temporary_file(tmp_);
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;
    fs::remove(tmp_, ec);
  }
  unregister_temporary_file(tmp_);
}

void AtomicFile::commit() {
  std::error_code ec;
  fs::rename(tmp_, path_, ec);
  if (ec) throw Error("{}: cannot write: {}", path_, ec.message());
  committed_ = true;
}

void write_text_file_atomic(const fs::path& path, std::string_view text) {
  fs::path parent = path.parent_path();
  if (!parent.empty() && !fs::is_directory(parent))
    throw Error("{}: folder {} does not exist", path.string(), parent.string());
  AtomicFile out(path);
  {
    std::ofstream f(out.tmp(), std::ios::binary | std::ios::trunc);
    if (!f) throw Error("{}: cannot write: {}", path.string(), std::strerror(errno));
    f.write(text.data(), static_cast<std::streamsize>(text.size()));
    f.flush();
    if (!f) throw Error("{}: cannot write: {}", path.string(), std::strerror(errno));
  }
  out.commit();
}

std::string read_text_file(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error("{}: no such file", path.string());
  if (fs::is_directory(path, ec)) throw Error("{}: is a folder, not a file", path.string());
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error("{}: cannot open: {}", path.string(), std::strerror(errno));
  std::ostringstream ss;
  ss << f.rdbuf();
  if (f.bad()) throw Error("{}: cannot read", path.string());
  return ss.str();
}

}  // namespace penumbra
