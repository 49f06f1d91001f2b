#include "penumbra/scene/generators.h"

#include <algorithm>
#include <climits>
#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/scene/json_reader.h"

namespace penumbra {

using nlohmann::json;

namespace {
std::vector<GeneratorInfo>& registry() {
  static std::vector<GeneratorInfo> r;
  return r;
}

// "an integer in [0, 1000000]", "a number >= 0.001"...
std::string describe_range(const GeneratorParam& p, bool integer) {
  const char* kind = integer ? "an integer" : "a number";
  bool lo = std::isfinite(p.min), hi = std::isfinite(p.max);
  if (lo && hi) return fmt::format("{} in [{}, {}]", kind, p.min, p.max);
  if (lo) return fmt::format("{} >= {}", kind, p.min);
  if (hi) return fmt::format("{} <= {}", kind, p.max);
  return kind;
}

// Rounds to 4 decimals so generated documents read 1.2, not 1.2000000476837158.
double tidy(float v) { return std::round(static_cast<double>(v) * 1e4) / 1e4; }
json tidy(Vec3f v) { return json::array({tidy(v.x), tidy(v.y), tidy(v.z)}); }
}  // namespace

GeneratorRegistration::GeneratorRegistration(GeneratorInfo info) {
  auto& r = registry();
  auto at = std::lower_bound(r.begin(), r.end(), info.name,
                             [](const GeneratorInfo& g, const std::string& n) { return g.name < n; });
  r.insert(at, std::move(info));
}

const std::vector<GeneratorInfo>& generators() { return registry(); }

const GeneratorInfo& find_generator(const std::string& name) {
  for (const auto& g : registry())
    if (g.name == name) return g;
  std::string names;
  for (const auto& g : registry()) names += (names.empty() ? "" : ", ") + g.name;
  throw Error("unknown generator \"{}\" (available: {})", name, names);
}

json resolve_generator_params(const GeneratorInfo& g, const JsonValue& user) {
  std::vector<std::string_view> names;
  for (const auto& p : g.params) names.push_back(p.name);
  user.expect_object(names);
  json out = json::object();
  for (const auto& p : g.params) {
    const json& d = p.default_value;
    if (!user.has(p.name)) {
      out[p.name] = d;
      continue;
    }
    JsonValue v = user[p.name];
    if (d.is_boolean()) {
      out[p.name] = v.boolean();
    } else if (d.is_number_integer()) {
      int lo = static_cast<int>(std::clamp(std::ceil(p.min), double{INT_MIN}, double{INT_MAX}));
      int hi = static_cast<int>(std::clamp(std::floor(p.max), double{INT_MIN}, double{INT_MAX}));
      if (!v.raw().is_number()) v.fail_expected(describe_range(p, true));
      out[p.name] = v.integer(lo, hi);
    } else if (d.is_number()) {
      std::string what = describe_range(p, false);
      if (!v.raw().is_number()) v.fail_expected(what);
      float x = v.number();
      if (x < p.min || x > p.max) v.fail_expected(what);
      out[p.name] = v.raw().get<double>();
    } else if (d.is_string()) {
      out[p.name] = v.string();
    } else {
      if (v.raw().type() != d.type() || (d.is_array() && v.raw().size() != d.size()))
        v.fail_expected(fmt::format("a value like {}", abbreviate_json(d)));
      out[p.name] = v.raw();
    }
  }
  return out;
}

json resolve_generator_params(const GeneratorInfo& g, const json& user, const std::string& where) {
  return resolve_generator_params(g, JsonValue(user, where));
}

json make_example_scene(const std::string& generator, const std::vector<std::string>& key_eq_values) {
  const GeneratorInfo& g = find_generator(generator);
  json user = json::object();
  for (const auto& kv : key_eq_values) {
    size_t eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) throw Error("--param {}: expected key=value", kv);
    std::string text = kv.substr(eq + 1);
    // "3000", "0.5", "true" are JSON; "abc" is not and stays a string.
    user[kv.substr(0, eq)] = parse_json_value_or_string(text, fmt::format("--param {}", kv.substr(0, eq)));
  }
  return g.example_scene(resolve_generator_params(g, user, fmt::format("scene {}", generator)));
}

json example_scene_document(const json& object, const ExampleSceneLayout& l) {
  json camera = {{"eye", tidy(l.eye)}, {"target", tidy(l.target)}, {"up", json::array({0, 1, 0})},
                 {"fov_y", tidy(l.fov_y)}, {"resolution", json::array({512, 512})},
                 {"samples_per_pixel", 1}};
  // The light faces the object; u along world x keeps its edges axis-aligned when it
  // faces straight down.
  json light = {{"type", "rect"},
                {"center", tidy(l.light_center)},
                {"normal", tidy(normalize(l.target - l.light_center))},
                {"u", json::array({1, 0, 0})},
                {"size", json::array({tidy(l.light_size.x), tidy(l.light_size.y)})},
                {"radiance", tidy(Vec3f(l.light_radiance))}};
  json ground = {{"name", "ground"},
                 {"shape", "plane"},
                 {"size", json::array({tidy(l.ground_size.x), tidy(l.ground_size.y)})},
                 {"material", {{"albedo", json::array({0.75, 0.75, 0.75})}}}};
  return {{"camera", camera}, {"lights", json::array({light})}, {"objects", json::array({ground, object})}};
}

}  // namespace penumbra
