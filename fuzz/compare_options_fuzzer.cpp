// libFuzzer target: what `penumbra compare` and `penumbra sweep` do with their options before
// the first render. The first line of the input is the --methods list ("all", names, specs
// such as "pcss:variant=xie2007"); every other line is a setting as -p, --set and each value
// of sweep's --param give it (spp, resolution, light.size_scale, generator.<param>,
// <method>.<param>, ...). They are applied to a small scene document with a generated knot,
// the scene is loaded, and every method's parameters are resolved and its memory estimated,
// as a compare does. Bad input must end in a penumbra::Error naming the key or value;
// anything else (a crash, a sanitizer report, another exception, a hang, a huge
// allocation) is a finding. Seeds: fuzz/corpus/compare_options.
//
//   build-san/fuzz_compare_options -max_total_time=600 -timeout=10 -rss_limit_mb=4096 out/corpus-co fuzz/corpus/compare_options
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/core/error.h"
#include "penumbra/eval/run_setup.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/shadow_method.h"

namespace {

const char* const kScene = R"({
  "camera": {"eye": [0, 1.6, 3.2], "target": [0, 0.4, 0], "fov_y": 40, "resolution": [32, 32]},
  "lights": [{"type": "rect", "center": [-1.2, 3.0, -0.8], "normal": [0.4051, -0.8777, 0.2701],
              "size": [1.5, 1.5], "radiance": [14, 14, 14]}],
  "objects": [
    {"name": "ground", "shape": "plane", "size": [8, 8]},
    {"generator": "knot", "params": {"p": 2, "q": 3}, "translate": [0, 0.5, 0]}
  ]
})";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  std::string methods_line, line;
  std::getline(in, methods_line);
  std::vector<std::string> settings;
  while (std::getline(in, line)) settings.push_back(line);
  try {
    const std::vector<std::string> methods = penumbra::expand_method_list(penumbra::split_list(methods_line));
    penumbra::RunSetup setup;
    setup.scene_doc = nlohmann::json::parse(kScene);
    setup.scene_path = "fuzz.json";
    for (const std::string& kv : settings) setup.apply(kv);
    setup.check_plain_params(methods);
    // The knot at its largest (20,000 segments x 256 sides, 10 M triangles) takes seconds
    // to generate under the sanitizers: a legal setting, not a parsing matter; skipped so
    // the fuzzer's time goes to the options.
    const nlohmann::json& knot = setup.scene_doc["objects"][1]["params"];
    const auto number = [&](const char* key, double fallback) {
      return knot.contains(key) && knot[key].is_number() ? knot[key].get<double>() : fallback;
    };
    if (number("segments", 400) * number("sides", 16) > 2e5) return 0;
    // A huge resolution is no allocation here: the estimate below is what a render checks
    // before it allocates.
    const penumbra::Scene scene = setup.load();
    for (const std::string& m : methods) {
      const penumbra::MethodSpec spec = penumbra::parse_method_spec(m);
      penumbra::RenderSettings rs;
      rs.method = spec.name;
      rs.params = setup.overrides_for(spec);
      rs.light_samples = setup.light_samples;
      rs.seed = setup.seed;
      penumbra::resolve_method_params(spec.name, scene, rs.params);
      (void)penumbra::estimate_render_memory(scene, rs);
    }
  } catch (const penumbra::Error&) {
  }
  return 0;
}
