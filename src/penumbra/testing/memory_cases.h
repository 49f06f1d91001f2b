// The memory-estimate checks of render/memory_estimate_test.cpp, declared by each method's own
// tests (beside the method, in its folder): what the estimate must grow with, and cases whose
// heap peak the estimate is compared with. A new method brings its cases with it and changes
// nothing outside its folder (issue 19: a needed outside change is a flaw in the interface).
// Header-only; used by *_test.cpp files only, registered from static objects:
//   static const testing::MemoryCaseRegistration memory_cases(
//       "lam", {"resolution", "max_layers", "triangles"}, {{"lam", {"resolution=512"}}});
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::testing {

// One render whose heap peak is measured against the estimate.
struct MemoryMeasureCase {
  std::string method;
  std::vector<std::string> params;  // chosen so that the method's maps (or lists) dominate
  int light_samples = 4;
  bool many_triangles = false;  // a scene of many small triangles instead of a few large ones
  int image = 32;               // camera resolution
};

struct MemoryCases {
  std::vector<MemoryMeasureCase> measure;
  // Per method: what its estimate must grow with: its size parameters by name, "--spp" and
  // "triangles" (the scene's).
  std::map<std::string, std::vector<std::string>> drivers;
};

inline MemoryCases& memory_cases() {
  static MemoryCases cases;
  return cases;
}

struct MemoryCaseRegistration {
  MemoryCaseRegistration(const std::string& method, std::vector<std::string> drivers,
                         std::vector<MemoryMeasureCase> measure) {
    memory_cases().drivers[method] = std::move(drivers);
    for (MemoryMeasureCase& c : measure) memory_cases().measure.push_back(std::move(c));
  }
};

}  // namespace penumbra::testing
