// libFuzzer target: method parameters as `-p key=value` gives them. The first line of the
// input names the method (or picks one from the registry by its first byte), the other lines
// are key=value overrides passed to create_method for a small scene. Bad values must end in
// a penumbra::Error naming the key; anything else is a finding. Seeds: fuzz/corpus/params.
//
//   build-san/fuzz_params -max_total_time=600 -timeout=10 -rss_limit_mb=4096 out/corpus-params fuzz/corpus/params
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/testing/test_scenes.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const penumbra::Scene scene = penumbra::testing::ground_scene(
      {penumbra::testing::object(penumbra::testing::box({-0.5f, 0.5f, -0.5f}, {0.5f, 1.0f, 0.5f}))},
      penumbra::testing::rect_light_down({0, 2, 0}, 1.0f, 1.0f), 16);
  static const auto methods = penumbra::MethodRegistry::all();
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::string name, line;
  std::getline(in, name);
  if (!penumbra::MethodRegistry::find(name)) name = methods[size ? data[0] % methods.size() : 0]->name;
  std::vector<std::string> overrides;
  while (std::getline(in, line)) overrides.push_back(line);
  try {
    auto method = penumbra::create_method(name, scene, overrides);
  } catch (const penumbra::Error&) {
  }
  return 0;
}
