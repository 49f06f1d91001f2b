#include "penumbra/eval/run_setup.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "penumbra/core/error.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/generators.h"
#include "penumbra/scene/json_reader.h"
#include "penumbra/gpu/device.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/shadow_method.h"

namespace penumbra {

using nlohmann::json;

namespace {

double parse_number(const std::string& key, const std::string& value) {
  const char* s = value.c_str();
  char* end = nullptr;
  errno = 0;
  double v = std::strtod(s, &end);
  if (value.empty() || end != s + value.size() || errno == ERANGE || !std::isfinite(v))
    throw Error("{}={}: expected a number", key, value);
  return v;
}

double parse_positive(const std::string& key, const std::string& value) {
  double v = parse_number(key, value);
  if (!(v > 0)) throw Error("{}={}: expected a positive number", key, value);
  return v;
}

long long parse_int(const std::string& key, const std::string& value, long long lo, long long hi) {
  double v = 0;
  try {
    v = parse_number(key, value);
  } catch (const Interrupted&) {
    throw;  // Ctrl-C ends the run, whatever this step would do with an error
  } catch (const Error&) {
    v = std::numeric_limits<double>::quiet_NaN();
  }
  if (!(v == std::floor(v)) || v < lo || v > hi)
    throw Error("{}={}: expected an integer in [{}, {}]", key, value, lo, hi);
  return static_cast<long long>(v);
}

// The value as JSON when it parses as JSON (3000, 0.5, true), else as a string.
json json_value(const std::string& key, const std::string& text) {
  return parse_json_value_or_string(text, "--param " + key);
}

json& lights_of(json& doc, const std::string& key) {
  if (!doc.contains("lights") || !doc["lights"].is_array() || doc["lights"].empty())
    throw Error("{}: the scene has no lights", key);
  return doc["lights"];
}

// Multiplies every light's size by s (rect: both sides; disk and sphere: the radius; ellipsoid: its radii).
void scale_light(json& light, double s, const std::string& key) {
  std::string type = light.value("type", "");
  if (type == "rect") {
    if (!light.contains("size") || !light["size"].is_array() || light["size"].size() != 2)
      throw Error("{}: a rect light without a two-number size", key);
    light["size"] = {light["size"][0].get<double>() * s, light["size"][1].get<double>() * s};
  } else if (type == "disk" || type == "sphere") {
    if (!light.contains("radius") || !light["radius"].is_number()) throw Error("{}: a {} light without a radius", key, type);
    light["radius"] = light["radius"].get<double>() * s;
  } else if (type == "ellipsoid") {
    if (!light.contains("radii") || !light["radii"].is_array() || light["radii"].size() != 3)
      throw Error("{}: an ellipsoid light without three radii", key);
    for (auto& r : light["radii"]) {
      if (!r.is_number()) throw Error("{}: an ellipsoid light without three radii", key);
      r = r.get<double>() * s;
    }
  } else {
    throw Error("{}: unknown light type '{}'", key, type);
  }
}

// The light's "size" as a sweep sees it: rect, its width (size[0]); disk and sphere, the
// diameter; ellipsoid, twice its largest semi-axis. Its "radius": the largest distance from
// the centre to a point of the light (AreaLight::extent_radius: the rect's half diagonal).
double light_measure(const json& light, bool radius) {
  std::string type = light.value("type", "");
  if (type == "rect") {
    double w = light["size"][0].get<double>(), h = light["size"][1].get<double>();
    return radius ? 0.5 * std::hypot(w, h) : w;
  }
  if (type == "ellipsoid") {
    double r = 0;
    for (const auto& x : light["radii"]) r = std::max(r, x.get<double>());
    return radius ? r : 2 * r;
  }
  double r = light["radius"].get<double>();
  return radius ? r : 2 * r;
}

}  // namespace

const std::vector<std::string>& run_setting_keys() {
  static const std::vector<std::string> keys = {"spp",   "reference_spp",    "seed",       "resolution",
                                                "pixel_samples", "light.size_scale", "light.size", "light.radius",
                                                "generator.<param>", "<method>.<param>", "<param>"};
  return keys;
}

std::vector<std::string> split_list(const std::string& text, char sep) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find(sep, start);
    if (end == std::string::npos) end = text.size();
    std::string item = text.substr(start, end - start);
    // Trim spaces ("a, b").
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (!item.empty()) out.push_back(item);
    start = end + 1;
  }
  return out;
}

MethodSpec parse_method_spec(const std::string& spec) {
  MethodSpec m;
  m.label = spec;
  std::vector<std::string> parts = split_list(spec, ':');
  if (parts.empty()) throw Error("--methods: empty method name");
  // name@device: gpu:N's number arrives as the next part.
  std::string name = parts[0];
  size_t first_param = 1;
  if (const size_t at = name.find('@'); at != std::string::npos) {
    m.device = name.substr(at + 1);
    name = name.substr(0, at);
    if (m.device == "gpu" && parts.size() > 1 && !parts[1].empty() &&
        parts[1].find_first_not_of("0123456789") == std::string::npos) {
      m.device += ":" + parts[1];
      first_param = 2;
    }
    try {
      gpu::DeviceChoice::parse(m.device);
    } catch (const Error&) {
      throw Error("--methods {}: device '{}' is not cpu, gpu or gpu:N", spec, m.device);
    }
  }
  m.name = MethodRegistry::get(name).name;  // throws listing the known methods
  if (!m.device.empty() && m.device != "cpu" && !find_gpu_method(m.name))
    throw Error("--methods {}: {} has no GPU version yet (`penumbra methods` lists the devices)", spec, m.name);
  for (size_t i = first_param; i < parts.size(); ++i) {
    auto eq = parts[i].find('=');
    if (eq == std::string::npos || eq == 0)
      throw Error("--methods {}: '{}' is not key=value (write method:key=value:key=value)", spec, parts[i]);
    m.params.push_back(parts[i]);
  }
  if (m.params.empty()) m.label = m.device.empty() ? m.name : m.name + "@" + m.device;  // "pcss:" is "pcss"
  return m;
}

std::vector<std::string> expand_method_list(const std::vector<std::string>& names) {
  std::vector<std::string> out;
  auto add = [&](const std::string& n) {
    if (std::find(out.begin(), out.end(), n) == out.end()) out.push_back(n);
  };
  for (const std::string& item : names) {
    for (const std::string& n : split_list(item)) {
      if (n == "all") {
        for (const MethodInfo* m : MethodRegistry::all()) add(m->name);
      } else {
        add(parse_method_spec(n).label);  // throws listing the known methods
      }
    }
  }
  if (out.empty()) throw Error("--methods: no method named");
  return out;
}

RunSetup RunSetup::from_file(const std::filesystem::path& scene_file) {
  RunSetup s;
  s.scene_doc = read_json_file(scene_file);
  if (!s.scene_doc.is_object()) throw Error("{}: expected a JSON object at the top level", scene_file.string());
  s.scene_path = scene_file;
  return s;
}

nlohmann::json run_setup_json(const RunSetup& setup) {
  nlohmann::json j = {{"scene_doc", setup.scene_doc},         {"scene_path", setup.scene_path.string()},
          {"light_samples", setup.light_samples}, {"reference_samples", setup.reference_samples},
          {"seed", setup.seed},                   {"method_params", setup.method_params},
          {"device", setup.device}};
  if (setup.frame >= 0) j["frame"] = setup.frame;  // absent for a static scene, as before
  return j;
}

RunSetup run_setup_from_json(const nlohmann::json& j) {
  RunSetup s;
  try {
    s.scene_doc = j.at("scene_doc");
    s.scene_path = j.at("scene_path").get<std::string>();
    s.light_samples = j.at("light_samples").get<int>();
    s.reference_samples = j.at("reference_samples").get<int>();
    s.seed = j.at("seed").get<uint64_t>();
    s.method_params = j.at("method_params").get<std::vector<std::string>>();
    s.frame = j.value("frame", -1);
    s.device = j.value("device", std::string("cpu"));
  } catch (const nlohmann::json::exception& e) {
    throw Error("run setup: {}", e.what());
  }
  if (!s.scene_doc.is_object()) throw Error("run setup: scene_doc: expected a JSON object");
  return s;
}

void RunSetup::apply(const std::string& key_eq_value) {
  auto eq = key_eq_value.find('=');
  if (eq == std::string::npos || eq == 0) throw Error("{}: expected key=value", key_eq_value);
  apply(key_eq_value.substr(0, eq), key_eq_value.substr(eq + 1));
}

void RunSetup::apply(const std::string& key, const std::string& value) {
  if (key == "spp") {
    light_samples = static_cast<int>(parse_int(key, value, 1, 1 << 20));
  } else if (key == "reference_spp") {
    reference_samples = static_cast<int>(parse_int(key, value, 1, 1 << 20));
  } else if (key == "seed") {
    seed = static_cast<uint64_t>(parse_int(key, value, 0, (1ll << 53)));
  } else if (key == "resolution") {
    int w = 0, h = 0;
    if (!parse_resolution(value, &w, &h))
      throw Error("{}={}: expected N or WxH with sides in [1, 16384], e.g. 256 or 512x384", key, value);
    scene_doc["camera"]["resolution"] = {w, h};
  } else if (key == "pixel_samples") {
    scene_doc["camera"]["samples_per_pixel"] = parse_int(key, value, 1, 65536);
  } else if (key == "light.size_scale") {
    double s = parse_positive(key, value);
    for (json& l : lights_of(scene_doc, key)) scale_light(l, s, key);
  } else if (key == "light.size" || key == "light.radius") {
    double target = parse_positive(key, value);
    for (json& l : lights_of(scene_doc, key)) {
      scale_light(l, 1.0, key);  // validates the light's fields
      scale_light(l, target / light_measure(l, key == "light.radius"), key);
    }
  } else if (key.rfind("light.", 0) == 0) {
    throw Error("{}: unknown light setting (light.size_scale, light.size, light.radius)", key);
  } else if (key.rfind("generator.", 0) == 0) {
    std::string param = key.substr(10);
    if (param.empty()) throw Error("{}: name a generator parameter, e.g. generator.leaves", key);
    int changed = 0;
    std::string seen;
    if (scene_doc.contains("objects") && scene_doc["objects"].is_array()) {
      for (json& obj : scene_doc["objects"]) {
        if (!obj.is_object() || !obj.contains("generator") || !obj["generator"].is_string()) continue;
        const GeneratorInfo& g = find_generator(obj["generator"].get<std::string>());
        seen += (seen.empty() ? "" : ", ") + g.name;
        bool has = std::any_of(g.params.begin(), g.params.end(), [&](const GeneratorParam& p) { return p.name == param; });
        if (!has) continue;
        if (!obj.contains("params") || !obj["params"].is_object()) obj["params"] = json::object();
        obj["params"][param] = json_value(key, value);
        ++changed;
      }
    }
    if (changed == 0)
      throw Error("{}: no generated object of the scene has a parameter '{}' (generators: {})", key, param,
                  seen.empty() ? "none" : seen);
  } else {
    auto dot = key.find('.');
    if (dot != std::string::npos) {
      std::string method = key.substr(0, dot);
      if (!MethodRegistry::find(method))
        throw Error("{}: unknown setting: '{}' is not a shadow method (settings: spp, reference_spp, seed, resolution, "
                    "pixel_samples, light.size_scale, light.size, light.radius, generator.<param>, <method>.<param>, "
                    "<param>)",
                    key, method);
      if (dot + 1 == key.size()) throw Error("{}: name a parameter after the method", key);
    }
    // Replace an earlier value of the same key (a sweep re-applies its key per value).
    std::string prefix = key + "=";
    method_params.erase(std::remove_if(method_params.begin(), method_params.end(),
                                       [&](const std::string& kv) { return kv.rfind(prefix, 0) == 0; }),
                        method_params.end());
    method_params.push_back(key + "=" + value);
  }
}

std::vector<std::string> RunSetup::overrides_for(const std::string& method, bool explicit_only) const {
  const MethodInfo& info = MethodRegistry::get(method);
  std::vector<std::string> plain, named;
  for (const std::string& kv : method_params) {
    auto eq = kv.find('=');
    std::string key = kv.substr(0, eq), value = kv.substr(eq + 1);
    auto dot = key.find('.');
    if (dot != std::string::npos) {
      if (key.substr(0, dot) == method) named.push_back(key.substr(dot + 1) + "=" + value);
    } else if (!explicit_only) {
      bool declared = std::any_of(info.params.begin(), info.params.end(), [&](const ParamSpec& p) { return p.name == key; });
      if (declared) plain.push_back(kv);
    }
  }
  plain.insert(plain.end(), named.begin(), named.end());
  return plain;
}

std::vector<std::string> RunSetup::overrides_for(const MethodSpec& spec) const {
  std::vector<std::string> o = overrides_for(spec.name);
  o.insert(o.end(), spec.params.begin(), spec.params.end());
  return o;
}

void RunSetup::check_plain_params(const std::vector<std::string>& methods) const {
  for (const std::string& kv : method_params) {
    std::string key = kv.substr(0, kv.find('='));
    if (key.find('.') != std::string::npos) continue;
    bool declared = false;
    for (const std::string& m : methods) {
      const MethodInfo& info = MethodRegistry::get(parse_method_spec(m).name);
      declared = declared || std::any_of(info.params.begin(), info.params.end(),
                                         [&](const ParamSpec& p) { return p.name == key; });
    }
    if (!declared) {
      std::string list;
      for (const auto& m : methods) list += (list.empty() ? "" : ", ") + m;
      throw Error("{}: no compared method has a parameter '{}' (methods: {}; address one method as "
                  "<method>.{}, see `penumbra methods NAME`)",
                  kv, key, list, key);
    }
  }
}

Scene RunSetup::load() const {
  Scene scene = parse_scene(scene_doc, scene_path);
  return frame < 0 ? scene : scene_at_frame(scene, frame);
}

namespace {
int camera_int(const json& doc, const char* key, int index, int fallback) {
  if (!doc.contains("camera") || !doc["camera"].is_object() || !doc["camera"].contains(key)) return fallback;
  const json& v = doc["camera"][key];
  if (index >= 0) return v.is_array() && v.size() > static_cast<size_t>(index) && v[index].is_number() ? v[index].get<int>() : fallback;
  return v.is_number() ? v.get<int>() : fallback;
}
}  // namespace

int RunSetup::width() const { return camera_int(scene_doc, "resolution", 0, 512); }
int RunSetup::height() const { return camera_int(scene_doc, "resolution", 1, 512); }
int RunSetup::pixel_samples() const { return camera_int(scene_doc, "samples_per_pixel", -1, 1); }

}  // namespace penumbra
