// The forest generator (issue 32): trees that are instances of a few shared tree meshes, each
// with its leaf triangles; deterministic from its seed; shared also from a scene file.
#include <set>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "penumbra/scene/generators.h"
#include "penumbra/scene/scene.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using nlohmann::json;
using testing::placed_exactly;
using testing::same_bits;

std::vector<SceneObject> forest(json params) {
  const GeneratorInfo& g = find_generator("forest");
  return g.generate(resolve_generator_params(g, params, "forest"));
}

TEST(Forest, TreesAreInstancesOfAFewMeshesWithTheirLeafTriangles) {
  const int trees = 9, kinds = 3, leaves = 400;
  const std::vector<SceneObject> parts = forest({{"trees", trees}, {"kinds", kinds}, {"leaves", leaves}, {"iterations", 6}});
  ASSERT_EQ(parts.size(), 2u * trees);  // stems and leaves per tree
  std::set<const TriangleMesh*> meshes;
  for (size_t i = 0; i < parts.size(); ++i) {
    const SceneObject& p = parts[i];
    ASSERT_TRUE(p.shared_mesh) << p.name;
    meshes.insert(p.shared_mesh.get());
    EXPECT_TRUE(placed_exactly(p)) << p.name;
    EXPECT_EQ(p.name, fmt::format("tree{}.{}", i / 2, i % 2 ? "leaves" : "stems"));
    if (i % 2) EXPECT_EQ(p.mesh.triangle_count(), 2u * leaves);  // two per leaf
    EXPECT_GE(p.mesh.bounds().lo.y, -1e-3f);                     // standing on y = 0
  }
  EXPECT_LE(meshes.size(), 2u * kinds);
  EXPECT_GE(meshes.size(), 4u);  // at least two kinds among nine trees
  // The defaults: 100 trees of 25,000 leaves are at least 5 M triangles (bench suite `wide`).
  const GeneratorInfo& g = find_generator("forest");
  const json defaults = resolve_generator_params(g, json::object(), "forest");
  EXPECT_EQ(defaults["trees"], 25);
  EXPECT_GE(100 * 2 * defaults["leaves"].get<int64_t>(), 5000000);
}

TEST(Forest, IsDeterministicFromItsSeed) {
  const json params = {{"trees", 4}, {"kinds", 2}, {"leaves", 200}, {"iterations", 5}};
  const std::vector<SceneObject> a = forest(params), b = forest(params);
  json other = params;
  other["seed"] = 2;
  const std::vector<SceneObject> c = forest(other);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), c.size());
  bool differs = false;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_TRUE(same_bits(a[i].mesh, b[i].mesh)) << i;
    differs = differs || !same_bits(a[i].mesh, c[i].mesh);
  }
  EXPECT_TRUE(differs);
}

TEST(Forest, MaskedLeavesCarryTheLeafImage) {
  const std::vector<SceneObject> parts =
      forest({{"trees", 2}, {"kinds", 1}, {"leaves", 50}, {"iterations", 5}, {"leaf_texture", "mask"}});
  const SceneObject& leaves = parts[1];
  EXPECT_TRUE(leaves.material.alpha_textured());
  EXPECT_EQ(leaves.mesh.uvs.size(), leaves.mesh.positions.size());
  EXPECT_EQ(leaves.material.alpha.texture, parts[3].material.alpha.texture);  // one image for all
}

TEST(Forest, FromASceneFileItsTreesStayShared) {
  json doc = testing::ground_scene_doc();
  doc["objects"].push_back({{"generator", "forest"},
                            {"params", {{"trees", 6}, {"kinds", 2}, {"leaves", 100}, {"iterations", 5}}},
                            {"translate", {1, 0, -2}},
                            {"rotate", {0, 30, 0}}});
  const Scene s = parse_scene(doc, "forest.json");
  ASSERT_EQ(s.objects.size(), 13u);
  std::set<const TriangleMesh*> meshes;
  for (size_t i = 1; i < s.objects.size(); ++i) {
    const SceneObject& o = s.objects[i];
    EXPECT_EQ(o.name.rfind("forest.tree", 0), 0u) << o.name;
    ASSERT_TRUE(o.shared_mesh) << o.name;
    meshes.insert(o.shared_mesh.get());
    EXPECT_TRUE(placed_exactly(o)) << o.name;
  }
  EXPECT_LE(meshes.size(), 4u);
  // The scene file's transform applies after the tree's own placement.
  const std::vector<SceneObject> parts = forest({{"trees", 6}, {"kinds", 2}, {"leaves", 100}, {"iterations", 5}});
  ObjectTransform t;
  t.translate = {1, 0, -2};
  t.rotate = {0, 30, 0};
  const Vec3f expected = t.matrix().transform_point(parts[0].mesh.positions[0]);
  const Vec3f got = s.objects[1].mesh.positions[0];
  EXPECT_NEAR(length(got - expected), 0.0f, 1e-4f);
}

TEST(Forest, ExampleSceneGrowsWithTheTrees) {
  const json small = make_example_scene("forest", {"trees=4", "leaves=10", "iterations=4"});
  const json big = make_example_scene("forest", {"trees=100", "leaves=10", "iterations=4"});
  const float ground_small = small["objects"][0]["size"][0].get<float>();
  const float ground_big = big["objects"][0]["size"][0].get<float>();
  EXPECT_NEAR(ground_big / ground_small, 11.0f / 3.0f, 1e-3f);  // (sqrt(trees) + 1) spacings
  const Scene s = parse_scene(big, "forest.json");
  EXPECT_EQ(s.objects.size(), 201u);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
