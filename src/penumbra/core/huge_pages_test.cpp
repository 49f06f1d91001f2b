#include "penumbra/core/huge_pages.h"

#include <gtest/gtest.h>

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

TEST(HugePages, TheKernelsModeIsTheBracketedWord) {
  EXPECT_EQ(bracketed_mode("always [madvise] never\n"), "madvise");
  EXPECT_EQ(bracketed_mode("[always] madvise never\n"), "always");
  EXPECT_EQ(bracketed_mode("always madvise [never]"), "never");
  EXPECT_EQ(bracketed_mode("always madvise never"), "");
  EXPECT_EQ(bracketed_mode("[always"), "");
  EXPECT_EQ(bracketed_mode(""), "");
  const std::string mode = transparent_huge_pages_mode();
  EXPECT_TRUE(mode.empty() || mode == "always" || mode == "madvise" || mode == "never") << mode;
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
