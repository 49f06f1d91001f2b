// Shared meshes through the renderer (issue 32): a scene whose objects place shared meshes
// (Embree instances) renders as the same scene with every object a mesh of its own, also
// while an animation moves the instances (SequenceRenderer: their transforms change, nothing
// is rebuilt).
#include <gtest/gtest.h>

#include <cmath>

#include "penumbra/render/renderer.h"
#include "penumbra/render/sequence_renderer.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/shapes.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using nlohmann::json;

RenderSettings reference_settings() {
  RenderSettings rs;
  rs.method = "reference";
  rs.light_samples = 16;
  return rs;
}

// Mean |dV| over the pixels, and the fraction of pixels whose V differs by more than 1e-4.
struct VDiff {
  double mean = 0, differing = 0;
};
VDiff v_diff(const Image& a, const Image& b) {
  VDiff d;
  const size_t n = a.pixel_count();
  for (size_t i = 0; i < n; ++i) {
    const double e = std::abs(a.pixel(i)[0] - b.pixel(i)[0]);
    d.mean += e / n;
    d.differing += e > 1e-4 ? 1.0 / n : 0.0;
  }
  return d;
}

// Hits through an instance equal the flat scene's within float rounding: a shadow ray may
// start a rounding away and, rarely, graze an edge on one side and not the other.
void expect_same_render(const Image& a, const Image& b) {
  const VDiff d = v_diff(a, b);
  EXPECT_LT(d.mean, 2e-4);
  EXPECT_LT(d.differing, 0.01);
}

TEST(Instancing, ReferenceRenderEqualsTheUnsharedScene) {
  const auto ball = std::make_shared<const TriangleMesh>(make_uv_sphere(0.4f, 24));
  Scene s = testing::instanced_scene(ball, 25, testing::rect_light_down({0.3f, 2.6f, -0.2f}, 1.2f, 0.9f), 64);
  s.camera.eye = {0.5f, 4.5f, 5.5f};
  s.camera.target = {0, 0.3f, 0};
  s.camera.up = {0, 1, 0};
  Renderer instanced(s, reference_settings()), flat(testing::unshared(s), reference_settings());
  ASSERT_EQ(instanced.tracer().instance_count(), 25u);
  ASSERT_EQ(flat.tracer().instance_count(), 0u);
  const RenderResult a = instanced.render(), b = flat.render();
  expect_same_render(a.visibility, b.visibility);
  // Some of it in shadow, some lit: the comparison sees both.
  const VDiff lit = v_diff(a.visibility, Image(a.visibility.width(), a.visibility.height(), 1, 1.0f));
  EXPECT_GT(lit.differing, 0.05);
  EXPECT_EQ(a.tracer["instances"], 25);
}

TEST(Instancing, AnimatedInstancesMoveByTheirTransforms) {
  // A small forest (shared tree meshes, each tree an instance) that an animation moves as one.
  const json doc = json::parse(R"({
    "camera": {"eye": [0, 5, 7], "target": [0, 0.5, 0], "resolution": [48, 48]},
    "lights": [{"type": "rect", "center": [-1, 6, 0.5], "normal": [0.15, -1, -0.1], "size": [1.5, 1.5]}],
    "objects": [
      {"shape": "plane", "size": [10, 10]},
      {"name": "woods", "generator": "forest",
       "params": {"trees": 4, "kinds": 2, "leaves": 300, "iterations": 5, "height": 2, "spacing": 2}}
    ],
    "animation": {"frames": 3, "objects": {"woods": {
      "translate": [{"frame": 0, "value": [0, 0, 0]}, {"frame": 2, "value": [0.6, 0, -0.4]}],
      "rotate": [{"frame": 0, "value": [0, 0, 0]}, {"frame": 2, "value": [0, 40, 0]}]}}}
  })");
  const Scene base = parse_scene(doc, "woods.json");
  ASSERT_EQ(base.objects.size(), 9u);
  SequenceRenderer sequence(base, reference_settings());
  for (int f = 0; f < 3; ++f) {
    SCOPED_TRACE(f);
    const SequenceRenderer::Frame frame = sequence.render(f);
    if (f > 0) {
      EXPECT_EQ(frame.moved_objects, 8);
      EXPECT_TRUE(frame.refit);  // the instances' transforms changed, nothing was rebuilt
    }
    const Scene at = scene_at_frame(base, f);
    const RenderResult fresh = render_scene(at, reference_settings());
    size_t shared = 0;  // the trees of a kind placed more than once (a kind placed once is not shared)
    for (const SceneObject& o : at.objects) shared += o.shared_mesh != nullptr;
    EXPECT_GE(shared, 4u);
    EXPECT_EQ(fresh.tracer["instances"], shared);
    expect_same_render(frame.result.visibility, fresh.visibility);
    expect_same_render(render_scene(testing::unshared(at), reference_settings()).visibility, fresh.visibility);
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
