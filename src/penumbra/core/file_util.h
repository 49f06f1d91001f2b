// Small file helpers. Outputs are written to a temporary file beside the target and
// renamed over it, so a failed or interrupted run never leaves a half-written file
// (DESIGN.md, conventions): rename within one folder is atomic on POSIX file systems.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace penumbra {

// A temporary file beside `path` ("<path>.tmp-<pid>"), renamed over `path` by commit() and
// removed by the destructor otherwise. Write to tmp() with any API (OpenEXR, stb, streams).
class AtomicFile {
 public:
  explicit AtomicFile(std::filesystem::path path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  const std::string& tmp() const { return tmp_; }
  // Renames the temporary file over the target; throws Error naming the target on failure.
  void commit();

 private:
  std::string path_, tmp_;
  bool committed_ = false;
};

// Writes `text` to `path` atomically (temporary file + rename). Errors name the file.
void write_text_file_atomic(const std::filesystem::path& path, std::string_view text);

// The whole file as a string. Errors ("no such file", "cannot read") name the file.
std::string read_text_file(const std::filesystem::path& path);

}  // namespace penumbra
