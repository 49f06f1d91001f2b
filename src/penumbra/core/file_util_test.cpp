#include "penumbra/core/file_util.h"

#include <filesystem>

#include <gtest/gtest.h>

#include "penumbra/core/error.h"
#include "penumbra/core/testing.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

namespace fs = std::filesystem;
using test::error_message;

TEST(FileUtil, AtomicWriteReplacesAndLeavesNoTemporary) {
  test::TempDir d("fileutil");
  fs::path f = d / "a.json";
  write_text_file_atomic(f, "first");
  write_text_file_atomic(f, "second\n");
  EXPECT_EQ(read_text_file(f), "second\n");
  int entries = 0;
  for (auto& e : fs::directory_iterator(d.path())) { (void)e; ++entries; }
  EXPECT_EQ(entries, 1);  // no leftover .tmp file
}

TEST(FileUtil, ErrorsNameTheFile) {
  EXPECT_NE(error_message([] { write_text_file_atomic("/nonexistent-penumbra-dir/x.json", "x"); })
                .find("/nonexistent-penumbra-dir/x.json"),
            std::string::npos);
  EXPECT_NE(error_message([] { read_text_file("/nonexistent-penumbra-dir/y.json"); }).find("y.json: no such file"),
            std::string::npos);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
