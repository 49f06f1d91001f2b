// A scene: a camera, area lights and triangle-mesh objects, loaded from a JSON scene file
// (docs/scene-format.md).
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/scene/camera.h"
#include "penumbra/scene/light.h"
#include "penumbra/scene/mesh.h"

namespace penumbra {

class Animation;

struct Scene {
  Camera camera;
  std::vector<AreaLight> lights;
  std::vector<SceneObject> objects;
  std::filesystem::path source;  // the scene file, for messages; empty when built in code
  // Per-method parameter defaults from the scene file's "methods" table:
  // {"lam": {"samples": 64}, ...}. The CLI's -p overrides them.
  nlohmann::json method_params = nlohmann::json::object();
  // The scene file's "animation" block (animation.h), or null: the camera, lights and objects
  // above are the scene as written, and scene_at_frame() gives it at a frame. Shared, never
  // changed, so copies of a scene (one per frame) do not copy the meshes it keeps.
  std::shared_ptr<const Animation> animation;

  Bounds3f bounds() const;
  size_t triangle_count() const;
  // Whether some object stops only part of the light (SceneObject::semi_transparent).
  bool semi_transparent() const;
  // After lights or objects change: orient sphere lights toward the scene, compute
  // SceneObject::closed. The loader calls it; code that builds scenes by hand should too.
  void finalize();
  // The part of finalize() that depends on the lights: after only the lights changed (the
  // viewer moving a light), without re-checking the meshes.
  void orient_sphere_lights();
};

// Points each sphere light's frame.n toward the centre of `scene_bounds` (Scene::finalize).
void orient_sphere_lights(std::vector<AreaLight>& lights, const Bounds3f& scene_bounds);

// Loads and validates a scene file. Every error (unknown key, wrong type, missing file,
// NaN/Inf, zero-size light, empty scene) throws penumbra::Error naming the file and the
// key path, e.g. "scenes/x.json: lights[0].size: must be two positive numbers".
Scene load_scene(const std::filesystem::path& path);
// The same from an already parsed document; `origin` is the file name used in messages
// and the folder that relative paths are resolved against.
Scene parse_scene(const nlohmann::json& doc, const std::filesystem::path& origin);
// A scene file's "camera" and "lights" values alone, validated exactly as in a scene file;
// messages start with `context` and name the key path ("camera.eye", "lights[0].size").
// parse_lights does not orient sphere lights (Scene::orient_sphere_lights does); a relative
// "radiance_texture" is found in `folder` (the scene file's).
Camera parse_camera(const nlohmann::json& camera, const std::string& context);
std::vector<AreaLight> parse_lights(const nlohmann::json& lights, const std::string& context,
                                    const std::filesystem::path& folder = {});

// The keys a scene file's camera, and a light of each shape, may hold (docs/scene-format.md).
const std::vector<std::string_view>& camera_keys();
const std::vector<std::string_view>& light_keys(LightShape shape);

// A scene file's "camera" and "lights" as resolved: the keys as written, and every key the
// file left out that has a default added with the value the parser took for it (camera `up`,
// `fov_y`, `resolution`, `samples_per_pixel`; a light's `radiance`, and `u` for every light
// that has a frame to give: the default rule's vector for a rect, the frame's first axis for
// a disk or ellipsoid). So a reader (the viewer's page, /api/state) needs no table of defaults:
// only `radiance_texture`, whose default is none, may be absent. `parsed` is what the
// document parsed to (parse_camera, parse_lights).
nlohmann::json resolved_camera_json(const nlohmann::json& camera, const Camera& parsed);
nlohmann::json resolved_lights_json(const nlohmann::json& lights, const std::vector<AreaLight>& parsed);

}  // namespace penumbra
