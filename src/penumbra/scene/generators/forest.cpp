// A forest (issue 32): `trees` procedural trees standing on a square that grows with
// sqrt(trees), each an instance of one of a few distinct tree meshes. A tree is the plant
// generator's (Honda's L-system skeleton as tapered tubes, small leaves on the twigs;
// generators/plant.cpp), grown at tree size with tens of thousands of leaves: about 50k
// triangles of leaves per tree by default. The trees share their meshes
// (SceneObject::shared_mesh): the ray tracer builds one BVH per distinct tree and an instance
// per tree, while every method still sees each tree's world-space triangles.
//
// Layout: the trees stand on a jittered grid of `spacing` (ceil(sqrt(trees)) cells a side,
// filled row by row), each turned about y, scaled by 0.8-1.2 and given one of the `kinds`
// meshes, all keyed by (seed, tree): the forest is a pure function of its parameters.
#include <cmath>
#include <memory>
#include <string>

#include "penumbra/core/rng.h"
#include "penumbra/scene/generators.h"
#include "penumbra/scene/generators/plant.h"

namespace penumbra {
namespace {

using nlohmann::json;

// Trees a side of the grid.
int grid_side(int trees) { return static_cast<int>(std::ceil(std::sqrt(static_cast<double>(trees)) - 1e-9)); }

std::vector<SceneObject> generate_forest(const json& params) {
  const uint64_t seed = params["seed"].get<uint64_t>();
  const int trees = params["trees"].get<int>(), kinds = params["kinds"].get<int>();
  const float spacing = params["spacing"].get<float>();
  const std::string leaf_texture = params["leaf_texture"].get<std::string>();

  // The distinct trees: the plant's, each from a seed of its own, its parts' meshes shared.
  PlantSettings plant;
  plant.leaves = params["leaves"].get<int>();
  plant.iterations = params["iterations"].get<int>();
  plant.height = params["height"].get<float>();
  plant.leaf_size = params["leaf_size"].get<float>();
  plant.trunk_radius = 0.012f;
  plant.branch_angle = 38.0f;
  plant.randomness = 0.35f;
  plant.sides = 6;
  plant.leaf_texture = leaf_texture;
  plant.leaf_texture_resolution = params["leaf_texture_resolution"].get<int>();
  if (leaf_texture == "mask") plant.leaf_image = plant_leaf_image(plant.leaf_texture_resolution);
  std::vector<std::vector<SceneObject>> kind_parts;
  for (int k = 0; k < kinds; ++k) {
    plant.seed = Rng(seed, 0x6b696e64 /* "kind" */, static_cast<uint64_t>(k)).next_u32() & 0x7fffffffu;
    std::vector<SceneObject> parts = grow_plant(plant);
    for (SceneObject& part : parts) part.shared_mesh = std::make_shared<const TriangleMesh>(std::move(part.mesh));
    kind_parts.push_back(std::move(parts));
  }

  std::vector<SceneObject> out;
  const int side = grid_side(trees);
  for (int i = 0; i < trees; ++i) {
    Rng rng(seed, 0x74726565 /* "tree" */, static_cast<uint64_t>(i));
    const float jx = rng.next_float() - 0.5f, jz = rng.next_float() - 0.5f;
    ObjectTransform t;
    t.translate = {(static_cast<float>(i % side) - 0.5f * static_cast<float>(side - 1) + 0.6f * jx) * spacing, 0.0f,
                   (static_cast<float>(i / side) - 0.5f * static_cast<float>(side - 1) + 0.6f * jz) * spacing};
    t.rotate = {0.0f, 360.0f * rng.next_float(), 0.0f};
    t.scale = Vec3f(0.8f + 0.4f * rng.next_float());
    const int kind = static_cast<int>(rng.uniform_int(static_cast<uint32_t>(kinds)));
    for (const SceneObject& part : kind_parts[kind]) {
      SceneObject o = part;  // the shared mesh, no mesh of its own yet
      o.name = "tree" + std::to_string(i) + "." + part.name;
      place_object(o, t);  // mesh = the shared mesh placed by t
      out.push_back(std::move(o));
    }
  }
  return out;
}

json forest_example(const json& params) {
  // The forest's square and a margin of one spacing.
  const float spacing = params["spacing"].get<float>(), height = params["height"].get<float>();
  const float extent = static_cast<float>(grid_side(params["trees"].get<int>()) + 1) * spacing;
  ExampleSceneLayout layout;
  layout.ground_size = {extent, extent};
  // From above one edge, over the forest toward its far side.
  layout.eye = Vec3f(0.08f * extent, 0.4f * extent + height, 0.62f * extent);
  layout.target = Vec3f(0.0f, 0.0f, -0.05f * extent);
  layout.fov_y = 50;
  // A sun-like light: far (1.2 x the square's side) and small (5.7 degrees across), from the
  // upper left, bright enough to give the ground about the irradiance of the other scenes.
  const float distance = 1.2f * extent;
  layout.light_center = layout.target + normalize(Vec3f(-0.45f, 1.0f, -0.3f)) * distance;
  layout.light_size = Vec2f(0.1f * distance, 0.1f * distance);
  layout.light_radiance = 350;
  json object = {{"generator", "forest"}, {"params", params}};
  return example_scene_document(object, layout);
}

GeneratorRegistration reg(GeneratorInfo{
    "forest",
    "procedural trees (the plant's L-system, tree-sized, ~50k leaf triangles each) on a square growing with "
    "sqrt(trees), each an instance of one of a few shared tree meshes",
    {
        {"seed", 1, "random seed: same seed, same forest", 0, 2147483647},
        {"trees", 25, "number of trees", 1, 10000},
        {"kinds", 4, "distinct tree meshes the trees are instances of", 1, 64},
        {"leaves", 25000, "leaves per tree (2 triangles each; 48 with leaf_texture = triangles)", 0, 1000000},
        {"height", 8.0, "height of a tree before its 0.8-1.2 scale", 1e-3, 1000},
        {"spacing", 8.0, "distance between neighbouring trees (a jittered grid)", 1e-3, 10000},
        {"iterations", 9, "L-system derivation steps of each tree (branching depth)", 1, 12},
        {"leaf_size", 0.04, "leaf length as a fraction of the tree's height (varies +-25%)", 1e-4, 1},
        {"leaf_texture", "none",
         "leaf shape, as the plant's: \"none\" (diamonds of 2 triangles), \"mask\" (alpha-masked quads with the "
         "plant's leaf image), \"triangles\" (the leaf outline in 48 triangles)"},
        {"leaf_texture_resolution", 128, "size of the leaf image in texels (leaf_texture = mask)", 8, 4096},
    },
    generate_forest,
    forest_example,
});

}  // namespace
}  // namespace penumbra
