// Procedural scene generators: the analogues of the papers' test scenes, each
// deterministic from its seed. Registered by name; usable from a scene file
// ({"generator": "plant", "params": {...}}) and from `penumbra scene NAME`.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/scene/mesh.h"

namespace penumbra {

struct GeneratorParam {
  std::string name;
  nlohmann::json default_value;
  std::string doc;
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

const std::vector<GeneratorInfo>& generators();
const GeneratorInfo& find_generator(const std::string& name);  // throws listing the names
// Validates user params (object, known keys, types matching defaults) and fills defaults.
// `where` prefixes error messages ("scene.json: objects[1].params").
nlohmann::json resolve_generator_params(const GeneratorInfo& g, const nlohmann::json& user,
                                        const std::string& where);

}  // namespace penumbra
