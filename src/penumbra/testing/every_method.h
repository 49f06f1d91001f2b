// A test suite parameterized by every registered method's name, one test per method:
//   INSTANTIATE_TEST_SUITE_P(Methods, Suite, ::testing::ValuesIn(testing::registered_method_names()),
//                            testing::method_test_name);
// Header-only; tests only.
#pragma once

#include <gtest/gtest.h>

#include <cctype>
#include <string>
#include <vector>

#include "penumbra/shadow/shadow_method.h"

namespace penumbra::testing {

inline std::vector<std::string> registered_method_names() {
  std::vector<std::string> names;
  for (const MethodInfo* info : MethodRegistry::all()) names.push_back(info->name);
  return names;
}

// The method's name as a test name (gtest allows letters, digits and '_').
inline std::string method_test_name(const ::testing::TestParamInfo<std::string>& info) {
  std::string n = info.param;
  for (char& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return n;
}

}  // namespace penumbra::testing
