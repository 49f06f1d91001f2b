#include "penumbra/core/file_util.h"

#include <filesystem>

#include <gtest/gtest.h>
#include <unistd.h>

#include "penumbra/core/error.h"

namespace penumbra {
namespace {

namespace fs = std::filesystem;

fs::path fresh_temp_dir(const char* name) {
  fs::path d = fs::temp_directory_path() / fmt::format("penumbra-{}-{}", name, ::getpid());
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

TEST(FileUtil, AtomicWriteReplacesAndLeavesNoTemporary) {
  fs::path d = fresh_temp_dir("fileutil");
  fs::path f = d / "a.json";
  write_text_file_atomic(f, "first");
  write_text_file_atomic(f, "second\n");
  EXPECT_EQ(read_text_file(f), "second\n");
  int entries = 0;
  for (auto& e : fs::directory_iterator(d)) { (void)e; ++entries; }
  EXPECT_EQ(entries, 1);  // no leftover .tmp file
  fs::remove_all(d);
}

TEST(FileUtil, ErrorsNameTheFile) {
  try {
    write_text_file_atomic("/nonexistent-penumbra-dir/x.json", "x");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-penumbra-dir/x.json"), std::string::npos);
  }
  try {
    read_text_file("/nonexistent-penumbra-dir/y.json");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("y.json: no such file"), std::string::npos);
  }
}

}  // namespace
}  // namespace penumbra
