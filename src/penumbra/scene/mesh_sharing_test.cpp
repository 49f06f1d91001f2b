// Mesh sharing (issue 32, SceneObject::shared_mesh): a mesh file placed by many objects is read
// once per load and shared; each object's world mesh is the shared mesh placed by its
// placement, bit for bit what placing an object of its own gives; animation keeps it so.
#include <gtest/gtest.h>

#include "penumbra/core/file_util.h"
#include "penumbra/core/testing.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/mesh_import.h"
#include "penumbra/scene/scene.h"
#include "penumbra/scene/shapes.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::placed_exactly;
using testing::same_bits;

// A UV sphere (with normals) as an OBJ file.
void write_ball_obj(const fs::path& path) {
  const TriangleMesh m = make_uv_sphere(0.5f, 24);
  std::string s;
  for (Vec3f p : m.positions) s += fmt::format("v {:.9g} {:.9g} {:.9g}\n", p.x, p.y, p.z);
  for (Vec3f n : m.normals) s += fmt::format("vn {:.9g} {:.9g} {:.9g}\n", n.x, n.y, n.z);
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    s += "f";
    for (int k = 0; k < 3; ++k) s += fmt::format(" {0}//{0}", m.indices[3 * t + k] + 1);
    s += "\n";
  }
  write_text_file_atomic(path, s);
}

// A scene document: the ground and `copies` objects placing ball.obj (written to `dir`) at
// testing::grid_placement(0), (1), ... (turned, scaled, mirrored, stretched).
json ball_scene(const test::TempDir& dir, int copies) {
  write_ball_obj(dir / "ball.obj");
  json doc = testing::ground_scene_doc();
  for (int i = 0; i < copies; ++i) {
    json o = testing::transform_json(testing::grid_placement(i));
    o["mesh"] = "ball.obj";
    doc["objects"].push_back(o);
  }
  return doc;
}

// The ball as an object of its own placed by `t` (what the loader gave before sharing).
TriangleMesh own_ball(const test::TempDir& dir, const ObjectTransform& t) {
  SceneObject own;
  own.mesh = import_mesh_parts(dir / "ball.obj").front().mesh;
  place_object(own, t);
  return own.mesh;
}

TEST(MeshSharing, AFilePlacedManyTimesIsReadOnceAndShared) {
  test::TempDir dir("sharing");
  json doc = ball_scene(dir, 25);
  fs::create_directories(dir / "sub");
  for (int i = 0; i < 25; i += 2) doc["objects"][1 + i]["mesh"] = "sub/../ball.obj";  // one file, two spellings
  const size_t reads = mesh_file_reads();
  const Scene s = parse_scene(doc, dir / "forest.json");
  EXPECT_EQ(mesh_file_reads() - reads, 1u);
  ASSERT_EQ(s.objects.size(), 26u);
  EXPECT_FALSE(s.objects[0].shared_mesh);  // the ground: an object of its own
  const TriangleMesh imported = import_mesh_parts(dir / "ball.obj").front().mesh;
  for (int i = 0; i < 25; ++i) {
    SCOPED_TRACE(i);
    const SceneObject& o = s.objects[1 + i];
    ASSERT_TRUE(o.shared_mesh);
    EXPECT_EQ(o.shared_mesh, s.objects[1].shared_mesh);
    EXPECT_TRUE(same_bits(*o.shared_mesh, imported));  // in the file's own space
    EXPECT_TRUE(placed_exactly(o));
    // Bit for bit what an object of its own gets.
    EXPECT_TRUE(same_bits(own_ball(dir, testing::grid_placement(i)), o.mesh));
    EXPECT_TRUE(o.closed);  // checked once, on the shared mesh
  }
  // A second load reads the file again (the cache lives for one load).
  parse_scene(doc, dir / "forest.json");
  EXPECT_EQ(mesh_file_reads() - reads, 2u + 25u + 1u);  // and the imports above
}

TEST(MeshSharing, AFilePlacedOnceIsAnObjectOfItsOwn) {
  test::TempDir dir("sharing-once");
  const Scene s = parse_scene(ball_scene(dir, 1), dir / "one.json");
  ASSERT_EQ(s.objects.size(), 2u);
  EXPECT_FALSE(s.objects[1].shared_mesh);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) EXPECT_EQ(s.objects[1].placement.m[r][c], r == c ? 1.0f : 0.0f);
}

TEST(MeshSharing, AnAnimatedInstanceKeepsItsPlacementAndItsMesh) {
  test::TempDir dir("sharing-anim");
  json doc = ball_scene(dir, 3);
  doc["objects"][2]["name"] = "mover";
  doc["animation"] = json::parse(R"({"frames": 5, "objects": {"mover": {
      "translate": [{"frame": 0, "value": [0, 0.5, 0]}, {"frame": 4, "value": [3, 1, -2]}],
      "scale": [{"frame": 0, "value": [-1, 1, 1]}, {"frame": 4, "value": [-0.8, 1.6, 1.2]}]}}})");
  const Scene base = parse_scene(doc, dir / "anim.json");
  ASSERT_TRUE(base.objects[2].shared_mesh);
  EXPECT_EQ(base.animation->movable_objects(), std::vector<uint32_t>{2});
  for (int f = 0; f < 5; ++f) {
    SCOPED_TRACE(f);
    const Scene s = scene_at_frame(base, f);
    const SceneObject& mover = s.objects[2];
    ASSERT_EQ(mover.shared_mesh, base.objects[1].shared_mesh);
    const Mat4 expected = base.animation->transform_at(base.animation->objects[0], f).matrix();
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) EXPECT_EQ(mover.placement.m[r][c], expected.m[r][c]);
    EXPECT_TRUE(placed_exactly(mover));
    EXPECT_TRUE(placed_exactly(s.objects[1]));  // the others stay
    EXPECT_TRUE(same_bits(s.objects[3].mesh, base.objects[3].mesh));
  }
}

TEST(MeshSharing, AnAnimatedMeshPlacedOnceStaysAnObjectOfItsOwn) {
  test::TempDir dir("sharing-anim-once");
  json doc = ball_scene(dir, 1);
  doc["objects"][1]["name"] = "mover";
  doc["animation"] = json::parse(R"({"frames": 3, "objects": {"mover": {
      "translate": [{"frame": 0, "value": [0, 0.5, 0]}, {"frame": 2, "value": [1, 1, 1]}]}}})");
  const Scene base = parse_scene(doc, dir / "anim.json");
  const Scene s = scene_at_frame(base, 2);
  EXPECT_FALSE(s.objects[1].shared_mesh);
  ObjectTransform t = testing::grid_placement(0);
  t.translate = {1, 1, 1};
  EXPECT_TRUE(same_bits(own_ball(dir, t), s.objects[1].mesh));
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
