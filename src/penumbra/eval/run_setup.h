// What one compare, sweep or bench run renders: a scene *document* (rewritten before it is
// loaded, so a sweep can change a light's size or a generator's tessellation), the render
// settings and per-method parameter overrides. Everything a run may vary is a "key=value"
// setting from one namespace (docs/compare.md, "Settings keys"):
//
//   spp, reference_spp, seed, resolution, pixel_samples      render settings
//   light.size_scale, light.size, light.radius               every light of the scene
//   generator.<param>                                        every generated object having <param>
//   <method>.<param>                                         one method's parameter
//   <param>                                                  every compared method declaring <param>
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/scene/scene.h"

namespace penumbra {

// One entry of a --methods list: a registered method, optionally on a device of its own and
// with parameters of its own, "name[@device]:key=value:key=value" (e.g. "pcss:variant=xie2007",
// "reference@gpu", "pcss@gpu:1:pcf_samples=16" is not: the device is cpu, gpu or gpu:N, so
// "pcss@gpu:1" names gpu:1), so that variants of one method and its CPU and GPU versions compare
// side by side. The label (the spec as written) names it in tables and plots.
struct MethodSpec {
  std::string label;                // "pcss@gpu:variant=xie2007"
  std::string name;                 // "pcss"
  std::string device;               // "gpu", "gpu:1", "cpu"; empty: the run's (RunSetup::device)
  std::vector<std::string> params;  // {"variant=xie2007"}
};
// Throws naming the spec for an unknown method or a parameter that is not key=value.
MethodSpec parse_method_spec(const std::string& spec);

struct RunSetup {
  nlohmann::json scene_doc = nlohmann::json::object();  // the scene file, as rewritten by settings
  std::filesystem::path scene_path;                      // messages; relative mesh paths
  int light_samples = 256;       // spp: light samples of every method that samples the light
  int reference_samples = 1024;  // reference_spp: light samples of the ground truth
  uint64_t seed = 0;
  // Method parameters in the order given: "method.key=value" and plain "key=value".
  std::vector<std::string> method_params;
  // The device every method renders on unless its spec names one (--device: cpu, gpu, gpu:N).
  // The ground truth renders on the CPU.
  std::string device = "cpu";
  // The frame of an animated scene this run renders (issue 18: `compare --frame-range`), or
  // -1: the scene as written. load() gives the scene at this frame, and the reference cache
  // keys each frame's ground truth apart (the document alone is the same for every frame).
  int frame = -1;

  // Reads a scene file (strict JSON with comments, as load_scene does).
  static RunSetup from_file(const std::filesystem::path& scene_file);

  // Applies one setting; throws an Error naming the key or value at fault.
  void apply(const std::string& key, const std::string& value);
  void apply(const std::string& key_eq_value);  // "key=value"

  // The parameter overrides for `method` (a registered name), as create_method takes them
  // ("key=value"): plain keys the method declares, then "method.key" ones. With
  // explicit_only, only the keys addressed to the method by name (the ground truth takes
  // those alone).
  std::vector<std::string> overrides_for(const std::string& method, bool explicit_only = false) const;
  // The same for a method spec: its method's overrides, then the spec's own parameters.
  std::vector<std::string> overrides_for(const MethodSpec& spec) const;
  // Throws unless every plain parameter key is declared by at least one of `methods`
  // (method specs: their methods count).
  void check_plain_params(const std::vector<std::string>& methods) const;

  // Parses the (rewritten) document into a Scene (at `frame` when it is >= 0).
  Scene load() const;
  // The camera resolution and samples per pixel of the document (defaults as the loader's).
  int width() const;
  int height() const;
  int pixel_samples() const;
};

// A RunSetup as one JSON object (scene_doc, scene_path, light_samples, reference_samples,
// seed, method_params): how `--dask` hands a run to penumbra.distributed and its jobs carry it.
nlohmann::json run_setup_json(const RunSetup& setup);
RunSetup run_setup_from_json(const nlohmann::json& j);  // throws an Error naming a missing key

// The settings keys that are not method parameters, for messages and docs.
const std::vector<std::string>& run_setting_keys();

// Expands a --methods list: "all" (every registered method), names, method specs
// ("pcss:variant=xie2007"), or a mix; keeps the order given, drops repeats, and throws
// naming an unknown method.
std::vector<std::string> expand_method_list(const std::vector<std::string>& names);
// Splits "a,b,c" at commas (empty items dropped).
std::vector<std::string> split_list(const std::string& text, char sep = ',');

}  // namespace penumbra
