// The two-level Embree scene with refittable objects (RayTracer's movable objects,
// update_objects): after moves, every query gives what a tracer built afresh for the moved
// scene gives; a non-movable object or a changed vertex count rebuilds the scene.
#include "penumbra/trace/ray_tracer.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "penumbra/core/rng.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// A ground, a box that moves and a half-transparent slab that moves.
Scene moving_scene() {
  std::vector<SceneObject> occluders;
  occluders.push_back(testing::object(testing::box({-0.5f, 0.3f, -0.4f}, {0.2f, 0.8f, 0.3f})));
  occluders.push_back(testing::object(testing::quad_y(1.2f, -0.3f, 0.9f, -0.6f, 0.6f), Vec3f(0.5f), 0.5f));
  return testing::ground_scene(std::move(occluders), testing::rect_light_down({0, 2, 0}, 1.0f, 0.8f), 16);
}

// Frame k's placement of the box (translated and turned) and the slab (slid).
Scene moved(const Scene& base, int k) {
  Scene s = base;
  ObjectTransform box;
  box.translate = {0.15f * k, 0.05f * k, -0.1f * k};
  box.rotate = {0, 17.0f * k, 5.0f * k};
  place_object(s.objects[1], box);
  ObjectTransform slab;
  slab.translate = {-0.2f * k, 0.0f, 0.1f * k};
  place_object(s.objects[2], slab);
  return s;
}

// Rays from above and from the side through the scene's middle.
std::vector<Ray> probe_rays() {
  std::vector<Ray> rays;
  Rng rng(7, 1, 2, 3);
  for (int i = 0; i < 4000; ++i) {
    const Vec2f a = rng.next_2d(), b = rng.next_2d();
    Ray r;
    r.org = {-2.0f + 4.0f * a.x, 3.0f, -2.0f + 4.0f * a.y};
    const Vec3f target = {-1.5f + 3.0f * b.x, 0.0f, -1.5f + 3.0f * b.y};
    r.dir = normalize(target - r.org);
    rays.push_back(r);
  }
  return rays;
}

// The hits and transmittances of `a` equal `b`'s: the same triangle at the same distance, or a
// tie (two triangles at one distance within rounding, an edge both contain: which of them
// the BVH reports first depends on its layout).
void expect_same_queries(const RayTracer& a, const RayTracer& b, int* ties) {
  const std::vector<Ray> rays = probe_rays();
  std::vector<Hit> ha(rays.size()), hb(rays.size());
  a.intersect(rays, ha);
  b.intersect(rays, hb);
  std::vector<ShadowRay> shadow;
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_EQ(ha[i].object, hb[i].object) << i;
    if (ha[i].object == Hit::kMiss) continue;
    if (ha[i].prim == hb[i].prim) {
      EXPECT_EQ(ha[i].t, hb[i].t) << i;
    } else {
      EXPECT_NEAR(ha[i].t, hb[i].t, 1e-5f * ha[i].t) << i;
      ++*ties;
    }
    const Vec3f p = rays[i].org + rays[i].dir * ha[i].t;
    shadow.push_back(shadow_ray_to(p, ha[i].ng, Vec3f(0.1f, 2.0f, -0.05f)));
  }
  std::vector<float> ta(shadow.size()), tb(shadow.size());
  a.transmittance(shadow, ta);
  b.transmittance(shadow, tb);
  int shadowed = 0, half = 0;
  for (size_t i = 0; i < shadow.size(); ++i) {
    EXPECT_EQ(ta[i], tb[i]) << i;
    shadowed += ta[i] == 0.0f;
    half += ta[i] > 0.0f && ta[i] < 1.0f;
  }
  EXPECT_GT(shadowed, 0);  // the probes see the box's shadow and through the slab
  EXPECT_GT(half, 0);
}

TEST(RayTracerRefit, MovedObjectsGiveTheQueriesOfAFreshBuild) {
  const Scene base = moving_scene();
  Scene current = base;
  const std::vector<uint32_t> movable = {1, 2};
  RayTracer refit(current, movable);
  int ties = 0;
  for (int k = 1; k <= 3; ++k) {
    SCOPED_TRACE(k);
    current = moved(base, k);
    refit.update_objects(current, movable);
    EXPECT_EQ(refit.refits(), k);
    EXPECT_EQ(refit.rebuilds(), 0);
    const RayTracer fresh(current);
    expect_same_queries(refit, fresh, &ties);
  }
  EXPECT_LT(ties, 20);  // rare: a handful of the 12000 rays at most
}

TEST(RayTracerRefit, AnObjectNotBuiltMovableOrWithOtherVerticesRebuilds) {
  const Scene base = moving_scene();
  Scene current = base;
  const std::vector<uint32_t> box = {1};
  RayTracer tracer(current, box);
  int ties = 0;
  // The slab was not built movable: the scene is rebuilt, still two-level with the box refittable.
  current = moved(base, 1);
  const std::vector<uint32_t> both = {1, 2};
  tracer.update_objects(current, both);
  EXPECT_EQ(tracer.rebuilds(), 1);
  EXPECT_EQ(tracer.refits(), 0);
  expect_same_queries(tracer, RayTracer(current), &ties);
  current = moved(base, 2);
  current.objects[2] = moved(base, 1).objects[2];
  tracer.update_objects(current, box);
  EXPECT_EQ(tracer.refits(), 1);
  expect_same_queries(tracer, RayTracer(current), &ties);
  // A box with another vertex count (a different mesh in its place): rebuilt.
  current.objects[1].mesh = testing::box({-0.2f, 0.2f, -0.2f}, {0.4f, 0.6f, 0.5f});
  current.objects[1].mesh.positions.push_back({9, 9, 9});  // an unused vertex
  tracer.update_objects(current, box);
  EXPECT_EQ(tracer.rebuilds(), 2);
  expect_same_queries(tracer, RayTracer(current), &ties);
}


// Issue 20: an alpha texture on a quad (2 x 1 texels, alpha 0 and 1: a bilinear ramp): shadow rays pass the mask's holes and stop at its solid
// part; blend keeps 1 - alpha; camera rays pass a hole and hit the ground below.
TEST(RayTracerAlpha, MaskHolesPassShadowAndCameraRaysBlendAttenuates) {
  auto ramp = std::make_shared<const Texture>(2, 1, std::vector<float>{1, 1, 1, 0, 1, 1, 1, 1}, true, "ramp");
  for (AlphaMode mode : {AlphaMode::Mask, AlphaMode::Blend}) {
    SCOPED_TRACE(to_string(mode));
    SceneObject leaf = testing::object(testing::quad_y(1.0f, -1, 1, -1, 1));
    leaf.mesh.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};  // u along x
    leaf.material.alpha = SurfaceAlpha{ramp, mode, 0.5f};
    std::vector<SceneObject> occluders;
    occluders.push_back(std::move(leaf));
    const Scene scene = testing::ground_scene(std::move(occluders), testing::rect_light_down({0, 2, 0}, 1, 1));
    const RayTracer tracer(scene);
    EXPECT_TRUE(tracer.has_transparency());
    for (float x : {-0.9f, -0.6f, -0.2f, 0.1f, 0.4f, 0.8f}) {
      // u = (x + 1) / 2; bilinear between the texel centres at u = 0.25 (alpha 0) and 0.75
      // (alpha 1), repeating: back down to 0 from u = 0.75 to 1.25.
      const float u = (x + 1) / 2;
      const float alpha = u < 0.25f ? 1 - (u + 0.25f) / 0.5f : u <= 0.75f ? (u - 0.25f) / 0.5f : 1 - (u - 0.75f) / 0.5f;
      const ShadowRay r = shadow_ray_to({x, 0, 0.3f}, {0, 1, 0}, {x, 1.9f, 0.3f});
      const float expected = mode == AlphaMode::Mask ? (alpha >= 0.5f ? 0.0f : 1.0f) : 1.0f - alpha;
      EXPECT_NEAR(tracer.transmittance(r), expected, 1e-4f) << "x = " << x;
      // Camera ray from above: the leaf where alpha reaches the cutoff, else the ground.
      Ray down;
      down.org = {x, 3, 0.3f};
      down.dir = {0, -1, 0};
      Hit hit;
      ASSERT_TRUE(tracer.intersect(down, &hit));
      EXPECT_EQ(hit.object, alpha >= 0.5f ? 1u : 0u) << "x = " << x;
    }
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
