// What the viewer's HTTP API accepts (docs/viewer.md), parsed and validated apart from the
// server: each function turns a request's body or query into a typed value or throws an
// Error with one line naming the key or value, and changes nothing on failure. Kept free of
// sockets and threads so the parsing is tested directly and fuzzed (fuzz/viewer_request_fuzzer.cpp).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/scene/scene.h"

namespace penumbra::viewer {

// The viewer's settings (POST /api/settings; docs/viewer.md, "Settings").
struct ViewerSettings {
  std::string preview = "auto";        // "auto" or a method name
  std::string final_method = "reference";
  std::string compare;                 // "" or a method rendered at the same view
  int spp = 32;                        // light samples per frame
  int frames = 16;                     // frames the final method accumulates
  // {"METHOD": {"key": value}}: merged over the scene file's "methods" table.
  nlohmann::json params = nlohmann::json::object();
  float preview_scale = 0;             // 0: auto; else a fixed fraction in (0, 1]
  float heatmap_scale = 0.25f;

  nlohmann::json to_json() const;
};

// The settings after applying `body` (a JSON object with any of ViewerSettings' keys) to
// `current`. Method names must be registered, and every method's parameters in "params"
// must be accepted by the method's table (resolve_method_params with `scene`'s own table). On a
// GPU session (`gpu`) the methods must have a GPU version.
ViewerSettings apply_settings(const ViewerSettings& current, const nlohmann::json& body, const Scene& scene,
                              bool gpu = false);

// The scene's "methods" table with the settings' parameters merged over it (what a render
// of the viewer uses, and what a saved scene file holds).
nlohmann::json merged_method_params(const Scene& scene, const ViewerSettings& settings);

// The current view: the scene-file JSON of the camera and of the lights, and what they parse to.
struct ViewState {
  nlohmann::json camera;  // as in a scene file ("eye", "target", ...)
  nlohmann::json lights;  // an array, as in a scene file
  Camera parsed_camera;
  std::vector<AreaLight> parsed_lights;  // sphere lights oriented toward `scene` (Scene::orient_sphere_lights)
  std::filesystem::path folder;          // the scene file's: where a light's radiance_texture is found

  // The camera and the lights with every default filled in (resolved_camera_json,
  // resolved_lights_json): what GET /api/state hands the page, which then reads no key the
  // scene file may leave out. `camera` and `lights` stay as written (a saved scene file).
  nlohmann::json resolved_camera() const;
  nlohmann::json resolved_lights() const;
};

// The view of a scene document (its "camera" and "lights"), parsed.
ViewState view_from_document(const nlohmann::json& scene_doc, const Scene& scene);

// POST /api/view: `patch` is a JSON merge patch (RFC 7386) of {"camera": {...}, "lights": [...]};
// the result is validated exactly as a scene file's camera and lights; sphere lights face the
// centre of `scene_bounds` (the scene's). `changed_camera` and
// `changed_lights` (optional) say what differs from `current`.
ViewState apply_view_patch(const ViewState& current, const nlohmann::json& patch, const Bounds3f& scene_bounds,
                           bool* changed_camera = nullptr, bool* changed_lights = nullptr);

// GET /api/frame's query: one finished frame, as `penumbra render` makes it.
struct FrameRequest {
  std::string method;
  int spp = 32;
  uint64_t seed = 0;
  int frames = 1;
  std::vector<std::string> params;  // "key=value", as -p
  int width = 0, height = 0;        // resolution=WxH; 0: the view's camera
  std::string format = "png";       // "png" or "exr"
};

// `query` as parsed from the URL (a key may repeat: "param"). Defaults: the settings' final
// method and spp, seed 0, frames 1, png. Unknown keys, bad numbers, unknown methods and
// formats throw naming the key and value.
FrameRequest parse_frame_request(const std::multimap<std::string, std::string>& query, const ViewerSettings& settings);

// The query of a request target ("/api/frame?method=pcss&param=bias=0.1" -> {method: pcss,
// param: bias=0.1}): split at '&', each part at its first '=' (so "param=KEY=VALUE" needs no
// escaping), '+' and %XX decoded. A malformed escape throws naming it.
std::multimap<std::string, std::string> parse_query_string(std::string_view target);

// A request body: strict JSON (parse_json_text's depth limit and duplicate-key check) that
// must be an object; `name` starts messages ("POST /api/view").
nlohmann::json parse_request_body(const std::string& body, const std::string& name);

// An integer query value in [lo, hi]; throws naming `key`.
int64_t parse_query_integer(const std::string& key, const std::string& value, int64_t lo, int64_t hi);

}  // namespace penumbra::viewer
