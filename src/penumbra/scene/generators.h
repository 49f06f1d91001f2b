// Procedural scene generators: the analogues of the papers' test scenes, each
// deterministic from its seed. Registered by name; usable from a scene file
// ({"generator": "plant", "params": {...}}) and from `penumbra scene NAME`.
#pragma once

#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/scene/mesh.h"

namespace penumbra {

class JsonValue;  // json_reader.h

// A parameter of a generator. Its type is the type of `default_value` (integer, float,
// bool, string); numbers must lie in [min, max].
struct GeneratorParam {
  std::string name;
  nlohmann::json default_value;
  std::string doc;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
};

struct GeneratorInfo {
  std::string name;
  std::string description;
  std::vector<GeneratorParam> params;
  // Builds the object(s) in the generator's own space (unit scale, resting on y = 0).
  // `params` has been validated against `params` (unknown keys rejected, defaults filled).
  std::function<std::vector<SceneObject>(const nlohmann::json& params)> generate;
  // A complete ready-to-render scene document around the generated object (ground plane,
  // camera, rect light), for `penumbra scene NAME`.
  std::function<nlohmann::json(const nlohmann::json& params)> example_scene;
};

// Every registered generator, sorted by name.
const std::vector<GeneratorInfo>& generators();
const GeneratorInfo& find_generator(const std::string& name);  // throws listing the names
// Validates user params (object, known keys, types matching defaults) and fills defaults.
// `where` prefixes error messages ("scene.json: objects[1].params").
nlohmann::json resolve_generator_params(const GeneratorInfo& g, const nlohmann::json& user,
                                        const std::string& where);
// The same with the parameters' location in a document: errors read
// "scene.json: objects[1].params.leaves: expected an integer in [0, 1000000], got -1".
nlohmann::json resolve_generator_params(const GeneratorInfo& g, const JsonValue& user);

// Generators register themselves from their own source file (generators/plant.cpp...):
//   static GeneratorRegistration reg(GeneratorInfo{...});
struct GeneratorRegistration {
  explicit GeneratorRegistration(GeneratorInfo info);
};

// For `penumbra scene NAME [--param k=v]...`: parses each "k=v" (v as JSON when it parses
// as JSON, e.g. 3000, 0.5, true; otherwise as a string), validates against the
// generator's table and returns g.example_scene(resolved params). Later duplicates win.
nlohmann::json make_example_scene(const std::string& generator,
                                  const std::vector<std::string>& key_eq_values);

// The common shape of the generators' example scenes: a ground plane, a camera and one
// rect light aimed at `target`, big enough for wide penumbrae. `object` is the scene-file
// object entry (the generator, its params and any transform).
struct ExampleSceneLayout {
  Vec3f eye{0, 1.6f, 3.2f}, target{0, 0.45f, 0};
  float fov_y = 40;
  Vec3f light_center{-1.2f, 3.0f, -0.8f};
  Vec2f light_size{1.5f, 1.5f};
  float light_radiance = 14;
  Vec2f ground_size{8, 8};
};
nlohmann::json example_scene_document(const nlohmann::json& object, const ExampleSceneLayout& layout);

}  // namespace penumbra
