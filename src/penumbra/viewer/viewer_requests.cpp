#include "penumbra/viewer/viewer_requests.h"

#include "penumbra/shadow/gpu_method.h"

#include <cerrno>
#include <cstdlib>

#include <fmt/format.h>

#include "penumbra/core/error.h"
#include "penumbra/scene/json_reader.h"
#include "penumbra/shadow/shadow_method.h"

namespace penumbra::viewer {

using nlohmann::json;

json ViewerSettings::to_json() const {
  return {{"preview", preview},
          {"final", final_method},
          {"compare", compare},
          {"spp", spp},
          {"frames", frames},
          {"params", params},
          {"preview_scale", preview_scale > 0 ? json(preview_scale) : json("auto")},
          {"heatmap_scale", heatmap_scale}};
}

namespace {

constexpr const char* kSettingsContext = "POST /api/settings";

std::string method_name(const JsonValue& v, bool allow_auto, bool allow_none, bool gpu = false) {
  std::string name = v.string();
  if ((allow_auto && name == "auto") || (allow_none && name.empty())) return name;
  if (!MethodRegistry::find(name)) {
    std::string known;
    for (const MethodInfo* m : MethodRegistry::all()) known += (known.empty() ? "" : ", ") + m->name;
    v.fail(fmt::format("unknown shadow method '{}' (known: {}{})", name, allow_auto ? "auto, " : "", known));
  }
  // A session on a GPU renders every frame there.
  if (gpu && !find_gpu_method(name))
    v.fail(fmt::format("{} has no GPU version yet, and this viewer renders on the GPU (penumbra view --device cpu)",
                       name));
  return name;
}

}  // namespace

ViewerSettings apply_settings(const ViewerSettings& current, const json& body, const Scene& scene, bool gpu) {
  JsonValue v(body, kSettingsContext);
  v.expect_object({"preview", "final", "compare", "spp", "frames", "params", "preview_scale", "heatmap_scale"});
  ViewerSettings s = current;
  if (v.has("preview")) s.preview = method_name(v["preview"], /*allow_auto=*/true, false, gpu);
  if (v.has("final")) s.final_method = method_name(v["final"], false, false, gpu);
  if (v.has("compare")) s.compare = method_name(v["compare"], false, /*allow_none=*/true, gpu);
  if (v.has("spp")) s.spp = v["spp"].integer(1, 1 << 20);
  if (v.has("frames")) s.frames = v["frames"].integer(1, 100000);
  if (v.has("preview_scale")) {
    JsonValue p = v["preview_scale"];
    if (p.raw().is_string() && p.raw().get<std::string>() == "auto") s.preview_scale = 0;
    else if (p.raw().is_number()) s.preview_scale = p.in_range(1.0f / 64, 1.0f);
    else p.fail_expected("\"auto\" or a fraction in [1/64, 1]");
  }
  if (v.has("heatmap_scale")) s.heatmap_scale = v["heatmap_scale"].in_range(1e-6f, 1e6f);
  if (v.has("params")) {
    JsonValue p = v["params"];
    p.expect_object();
    for (const auto& [name, table] : p.raw().items()) {
      const json name_value = name;  // (JsonValue keeps a pointer: not a temporary)
      method_name(JsonValue(name_value, kSettingsContext, "params"), false, false);
      // null removes the method's table (RFC 7386), an object is merged key by key.
      if (!table.is_null()) p[name].expect_object();
    }
    s.params.merge_patch(p.raw());
    // Every table must be one its method accepts, over the scene file's own table.
    for (const auto& [name, table] : s.params.items()) {
      const MethodInfo& info = MethodRegistry::get(name);
      ParamSet params(info.params, name);
      if (scene.method_params.is_object() && scene.method_params.contains(name))
        params.set_from_json(scene.method_params[name], fmt::format("{}: methods", scene.source.string()));
      params.set_from_json(table, fmt::format("{}: params", kSettingsContext));
      info.create(params);  // a method may refuse a combination of values
    }
  }
  return s;
}

json merged_method_params(const Scene& scene, const ViewerSettings& settings) {
  json table = scene.method_params.is_object() ? scene.method_params : json::object();
  table.merge_patch(settings.params);
  return table;
}

json ViewState::resolved_camera() const { return resolved_camera_json(camera, parsed_camera); }
json ViewState::resolved_lights() const { return resolved_lights_json(lights, parsed_lights); }

ViewState view_from_document(const json& scene_doc, const Scene& scene) {
  ViewState v;
  v.camera = scene_doc.at("camera");
  v.lights = scene_doc.at("lights");
  const std::string context = scene.source.string();
  v.parsed_camera = parse_camera(v.camera, context);
  v.folder = scene.source.parent_path();
  v.parsed_lights = parse_lights(v.lights, context, v.folder);
  orient_sphere_lights(v.parsed_lights, scene.bounds());
  return v;
}

ViewState apply_view_patch(const ViewState& current, const json& patch, const Bounds3f& scene_bounds, bool* changed_camera,
                           bool* changed_lights) {
  constexpr const char* kContext = "POST /api/view";
  JsonValue p(patch, kContext);
  p.expect_object({"camera", "lights"});
  ViewState next = current;
  if (p.has("camera")) {
    // A null camera would remove the camera (RFC 7386); the scene format needs one.
    if (!patch["camera"].is_object()) p["camera"].fail_expected("an object (a merge patch of the camera)");
    next.camera.merge_patch(patch["camera"]);
  }
  if (p.has("lights")) {
    if (!patch["lights"].is_array()) p["lights"].fail_expected("an array of lights (arrays are replaced whole)");
    next.lights = patch["lights"];
  }
  next.parsed_camera = parse_camera(next.camera, kContext);
  next.parsed_lights = parse_lights(next.lights, kContext, next.folder);
  orient_sphere_lights(next.parsed_lights, scene_bounds);
  if (changed_camera) *changed_camera = next.camera != current.camera;
  if (changed_lights) *changed_lights = next.lights != current.lights;
  return next;
}

int64_t parse_query_integer(const std::string& key, const std::string& value, int64_t lo, int64_t hi) {
  errno = 0;
  char* end = nullptr;
  const long long x = value.empty() ? 0 : std::strtoll(value.c_str(), &end, 10);
  if (value.empty() || errno != 0 || *end != '\0' || x < lo || x > hi)
    throw Error("{}={}: expected an integer in [{}, {}]", key, abbreviate_json(json(value)), lo, hi);
  return x;
}

FrameRequest parse_frame_request(const std::multimap<std::string, std::string>& query, const ViewerSettings& settings) {
  FrameRequest r;
  r.method = settings.final_method;
  r.spp = settings.spp;
  for (const auto& [key, value] : query) {
    if (key == "method") {
      if (!MethodRegistry::find(value)) throw Error("method={}: unknown shadow method", abbreviate_json(json(value)));
      r.method = value;
    } else if (key == "spp") {
      r.spp = static_cast<int>(parse_query_integer(key, value, 1, 1 << 20));
    } else if (key == "seed") {
      r.seed = static_cast<uint64_t>(parse_query_integer(key, value, 0, INT64_MAX));
    } else if (key == "frames") {
      r.frames = static_cast<int>(parse_query_integer(key, value, 1, 100000));
    } else if (key == "param") {
      if (value.find('=') == std::string::npos || value.front() == '=')
        throw Error("param={}: expected KEY=VALUE", abbreviate_json(json(value)));
      r.params.push_back(value);
    } else if (key == "resolution") {
      // As --resolution takes it.
      if (!parse_resolution(value, &r.width, &r.height))
        throw Error("resolution={}: expected N or WxH with sides in [1, 16384], e.g. 256 or 512x384",
                    abbreviate_json(json(value)));
    } else if (key == "format") {
      if (value != "png" && value != "exr") throw Error("format={}: expected png or exr", abbreviate_json(json(value)));
      r.format = value;
    } else {
      throw Error("{}: unknown query key (allowed: method, spp, seed, frames, param, resolution, format)",
                  abbreviate_json(json(key)));
    }
  }
  return r;
}

namespace {
std::string url_decode(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '+') {
      out += ' ';
    } else if (c == '%') {
      auto hex = [](char h) -> int {
        if (h >= '0' && h <= '9') return h - '0';
        if (h >= 'a' && h <= 'f') return h - 'a' + 10;
        if (h >= 'A' && h <= 'F') return h - 'A' + 10;
        return -1;
      };
      const int hi = i + 2 < text.size() ? hex(text[i + 1]) : -1, lo = i + 2 < text.size() ? hex(text[i + 2]) : -1;
      if (hi < 0 || lo < 0)
        throw Error("{}: a '%' must be followed by two hexadecimal digits", abbreviate_json(json(std::string(text))));
      out += static_cast<char>(hi * 16 + lo);
      i += 2;
    } else {
      out += c;
    }
  }
  return out;
}
}  // namespace

std::multimap<std::string, std::string> parse_query_string(std::string_view target) {
  std::multimap<std::string, std::string> out;
  const size_t q = target.find('?');
  if (q == std::string_view::npos) return out;
  std::string_view rest = target.substr(q + 1);
  const size_t hash = rest.find('#');
  if (hash != std::string_view::npos) rest = rest.substr(0, hash);
  while (!rest.empty()) {
    const size_t amp = rest.find('&');
    const std::string_view part = rest.substr(0, amp);
    rest = amp == std::string_view::npos ? std::string_view() : rest.substr(amp + 1);
    if (part.empty()) continue;
    const size_t eq = part.find('=');
    if (eq == std::string_view::npos) out.emplace(url_decode(part), "");
    else out.emplace(url_decode(part.substr(0, eq)), url_decode(part.substr(eq + 1)));
  }
  return out;
}

json parse_request_body(const std::string& body, const std::string& name) {
  json doc = parse_json_text(body, name);
  if (!doc.is_object()) throw Error("{}: expected a JSON object, got {}", name, abbreviate_json(doc));
  return doc;
}

}  // namespace penumbra::viewer
