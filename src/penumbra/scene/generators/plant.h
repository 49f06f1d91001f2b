// The plant generator's tree (generators/plant.cpp: Honda's L-system skeleton as tapered
// tubes, small leaves on its twigs), for the generators that grow several (forest.cpp).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "penumbra/scene/mesh.h"

namespace penumbra {

// The plant generator's parameters (docs/scene-format.md, `plant`), with its defaults.
struct PlantSettings {
  uint64_t seed = 1;
  int leaves = 3000, iterations = 9, sides = 5;
  float height = 1.0f, leaf_size = 0.06f, trunk_radius = 0.015f, branch_angle = 45.0f, randomness = 0.3f;
  std::string leaf_texture = "none";  // "none", "mask" or "triangles"
  int leaf_texture_resolution = 128;
  // With leaf_texture = "mask": the leaf image to use (plant_leaf_image); null: made here.
  std::shared_ptr<const Texture> leaf_image;
};

// The plant as two parts on y = 0, trunk base at the origin: "stems" and "leaves".
std::vector<SceneObject> grow_plant(const PlantSettings& settings);
// The RGBA leaf image of leaf_texture = "mask" (the leaf's outline as alpha), resolution^2 texels.
std::shared_ptr<const Texture> plant_leaf_image(int resolution);

}  // namespace penumbra
