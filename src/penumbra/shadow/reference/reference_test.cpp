// The ground truth must itself be right: closed forms, symmetry, transmittance, robust
// offsets, determinism.
#include <gtest/gtest.h>

#include <cmath>

#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/testing/memory_cases.h"
#include "penumbra/testing/test_scenes.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::ground_scene;
using testing::object;
using testing::quad_y;
using testing::rect_light_down;

ViewSample ground_point(Vec3f p) {
  ViewSample s;
  s.p = p;
  s.ng = s.ns = {0, 1, 0};
  s.albedo = Vec3f(1.0f);
  return s;
}

struct Evaluated {
  std::vector<float> v;
  std::vector<Vec3f> e;
  uint64_t rays;
};

Evaluated evaluate(const std::string& method, const Scene& scene, const std::vector<ViewSample>& pts, int spp,
                   std::vector<std::string> params = {}) {
  RayTracer tracer(scene);
  auto m = create_method(method, scene, params);
  ShadowContext ctx;
  ctx.scene = &scene;
  ctx.light = &scene.lights[0];
  ctx.tracer = &tracer;
  ctx.seed = 1;
  ctx.light_samples = spp;
  ViewSamples vs;
  vs.width = static_cast<int>(pts.size());
  vs.height = 1;
  vs.samples = pts;
  for (size_t i = 0; i < pts.size(); ++i) vs.samples[i].pixel = static_cast<uint32_t>(i);
  Evaluated r{std::vector<float>(pts.size(), -1.0f), std::vector<Vec3f>(pts.size()), 0};
  m->prepare(ctx);
  ShadowOutput out{r.v, r.e};
  m->evaluate(ctx, vs, out);
  r.rays = m->stats().rays_traced;
  return r;
}

TEST(Reference, UnoccludedPointsSeeTheWholeLightAndTheClosedFormIrradiance) {
  Scene scene = ground_scene({}, rect_light_down({0, 2, 0}, 1.5f, 1.0f));
  std::vector<ViewSample> pts = {ground_point({0, 0, 0}), ground_point({1.3f, 0, -0.7f}), ground_point({-2.5f, 0, 2})};
  for (const char* sampling : {"solid-angle", "area"}) {
    Evaluated r = evaluate("reference", scene, pts, 1024, {std::string("sampling=") + sampling});
    for (size_t i = 0; i < pts.size(); ++i) {
      EXPECT_EQ(r.v[i], 1.0f) << sampling;  // no acne: not one of 1024 rays blocked
      float expected = scene.lights[0].unshadowed_irradiance_scalar(pts[i].p, pts[i].ns);
      EXPECT_NEAR(r.e[i].x, expected, 5e-3f * expected) << sampling << " point " << i;
    }
    EXPECT_EQ(r.rays, 3u * 1024u);
  }
}

TEST(Reference, HalfPlaneThroughTheLightCentreHidesHalfTheLight) {
  // An occluding half-plane at y = 1 covering x < 0: from the origin, a light point at
  // (x, 2, z) is hidden exactly when x < 0, so V = 1/2 by symmetry of the rect light.
  Scene scene = ground_scene({object(quad_y(1.0f, -50, 0, -50, 50))}, rect_light_down({0, 2, 0}, 1.0f, 1.0f));
  for (const char* sampling : {"solid-angle", "area"}) {
    Evaluated r = evaluate("reference", scene, {ground_point({0, 0, 0})}, 1024, {std::string("sampling=") + sampling});
    EXPECT_NEAR(r.v[0], 0.5f, 0.01f) << sampling;
  }
}

TEST(Reference, SemiTransparentCastersMultiplyTransmittance) {
  // Three stacked planes of opacity 0.4 between the light and the point: V = 0.6^3.
  std::vector<SceneObject> layers;
  for (float y : {0.5f, 1.0f, 1.5f}) layers.push_back(object(quad_y(y, -50, 50, -50, 50), Vec3f(0.5f), 0.4f));
  Scene scene = ground_scene(std::move(layers), rect_light_down({0, 2, 0}, 1.0f, 1.0f));
  Evaluated r = evaluate("reference", scene, {ground_point({0, 0, 0})}, 64);
  EXPECT_NEAR(r.v[0], std::pow(0.6f, 3.0f), 1e-4f);
  Evaluated h = evaluate("hard", scene, {ground_point({0, 0, 0})}, 1);
  EXPECT_NEAR(h.v[0], std::pow(0.6f, 3.0f), 1e-4f);
}

TEST(Hard, ContactShadowsDoNotLeak) {
  // A box standing on the ground (bottom face in the ground plane). A low light on the
  // +x side: ground points just left of the box, 1e-3 from its wall, are in shadow; a
  // point just right of it is lit.
  AreaLight light = rect_light_down({6, 0.5f, 0}, 0.1f, 0.1f);
  light.frame = Frame::from_zx({-1, 0, 0}, {0, 0, 1});
  Scene scene = ground_scene({object(testing::box({-1, 0, -1}, {1, 1, 1}))}, light);
  Evaluated r = evaluate("hard", scene, {ground_point({-1.001f, 0, 0}), ground_point({1.001f, 0, 0}),
                                         ground_point({-1.00001f, 0, 0.5f})}, 1);
  EXPECT_EQ(r.v[0], 0.0f);
  EXPECT_EQ(r.v[1], 1.0f);
  EXPECT_EQ(r.v[2], 0.0f);
}

TEST(Reference, SameSeedSameImageForAnyThreadCount) {
  Scene scene = ground_scene({object(quad_y(1.0f, -0.5f, 0.7f, -0.3f, 0.4f))}, rect_light_down({0, 2, 0}, 1.5f, 1.5f), 24);
  RenderSettings settings;
  settings.light_samples = 16;
  settings.seed = 9;
  RenderResult a, b;
  {
    ThreadLimit one(1);
    a = render_scene(scene, settings);
  }
  {
    ThreadLimit two(2);
    b = render_scene(scene, settings);
  }
  ASSERT_EQ(a.color.data().size(), b.color.data().size());
  EXPECT_EQ(a.color.data(), b.color.data());
  EXPECT_EQ(a.visibility.data(), b.visibility.data());
  // And the penumbra is really there: some pixels strictly between 0 and 1.
  int partial = 0;
  for (float v : a.visibility.data()) partial += (v > 0.05f && v < 0.95f);
  EXPECT_GT(partial, 10);
}

TEST(RayTracer, FanTransmittanceEqualsOneRayAtATime) {
  // transmittance_fan (the reference's path: no ShadowRay set-up, unnormalised directions)
  // answers what transmittance(shadow_ray_to(...)) answers, ray by ray, through opaque and
  // semi-transparent casters, for fans of any length (chunks of 256, a ragged tail).
  std::vector<SceneObject> objects;
  objects.push_back(object(quad_y(0.6f, -0.4f, 0.3f, -0.5f, 0.2f)));
  objects.push_back(object(quad_y(1.1f, -0.2f, 0.6f, -0.1f, 0.7f), Vec3f(0.5f), 0.35f));
  objects.push_back(object(testing::box({0.3f, 0, -0.6f}, {0.5f, 0.4f, -0.3f})));
  Scene scene = ground_scene(std::move(objects), rect_light_down({0, 2, 0}, 1.5f, 1.5f));
  RayTracer tracer(scene);
  Rng rng(11);
  int rays = 0, equal = 0;
  for (int point = 0; point < 40; ++point) {
    const Vec2f u = rng.next_2d();
    const Vec3f p(-1.0f + 2.0f * u.x, 0.0f, -1.0f + 2.0f * u.y);
    const size_t n = point == 0 ? 300 : 1 + point * 7 % 61;
    std::vector<float> x(n), y(n), z(n), fan(n);
    std::vector<ShadowRay> one(n);
    for (size_t i = 0; i < n; ++i) {
      const Vec2f v = rng.next_2d();
      const Vec3f q(-0.75f + 1.5f * v.x, 2.0f, -0.75f + 1.5f * v.y);
      x[i] = q.x - p.x;
      y[i] = q.y - p.y;
      z[i] = q.z - p.z;
      one[i] = shadow_ray_to(p, {0, 1, 0}, q);
    }
    std::vector<float> single(n);
    tracer.transmittance(one, single);
    tracer.transmittance_fan(p, {0, 1, 0}, x.data(), y.data(), z.data(), n, fan.data());
    for (size_t i = 0; i < n; ++i) {
      ++rays;
      equal += std::abs(fan[i] - single[i]) <= 1e-6f;
      EXPECT_GE(fan[i], 0.0f);
      EXPECT_LE(fan[i], 1.0f);
    }
  }
  // Rays grazing an edge may round differently; nothing else may differ.
  EXPECT_GE(equal, rays - rays / 500) << equal << " of " << rays;
}

TEST(RayTracer, StreamIntersectEqualsOneRayAtATime) {
  // intersect(span) (the camera pass's rtcIntersect1M streams) finds, ray by ray, the hit
  // intersect(ray) finds, misses included, for any number of rays (chunks of 256, a ragged tail).
  std::vector<SceneObject> objects;
  objects.push_back(object(quad_y(0.6f, -0.4f, 0.3f, -0.5f, 0.2f)));
  objects.push_back(object(testing::box({0.3f, 0, -0.6f}, {0.5f, 0.4f, -0.3f})));
  Scene scene = ground_scene(std::move(objects), rect_light_down({0, 2, 0}, 1.5f, 1.5f));
  RayTracer tracer(scene);
  Rng rng(17);
  const Vec3f eye(0.2f, 1.5f, 2.5f);
  std::vector<Ray> rays(600);
  for (Ray& r : rays) {
    const Vec2f u = rng.next_2d();
    // Directions toward the scene and some above it (misses).
    r = Ray{eye, normalize(Vec3f(-2.0f + 4.0f * u.x, -2.5f + 3.5f * u.y, -2.5f)), 0.0f, kInfinity};
  }
  std::vector<Hit> hits(rays.size());
  tracer.intersect(rays, hits);
  int hit_count = 0, miss_count = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    Hit one;
    if (!tracer.intersect(rays[i], &one)) {
      EXPECT_EQ(hits[i].object, Hit::kMiss) << "ray " << i;
      ++miss_count;
      continue;
    }
    ++hit_count;
    EXPECT_EQ(hits[i].object, one.object) << "ray " << i;
    EXPECT_EQ(hits[i].prim, one.prim) << "ray " << i;
    EXPECT_FLOAT_EQ(hits[i].t, one.t) << "ray " << i;
    EXPECT_FLOAT_EQ(hits[i].u, one.u) << "ray " << i;
    EXPECT_FLOAT_EQ(hits[i].v, one.v) << "ray " << i;
  }
  EXPECT_GT(hit_count, 100);
  EXPECT_GT(miss_count, 10);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// The memory-estimate checks (render/memory_estimate_test.cpp, testing/memory_cases.h): what
// each estimate must grow with, and a case whose maps dominate the heap.
const testing::MemoryCaseRegistration kReferenceMemory(
    "reference", {"--spp"},
    {// Per-thread light samples only: many of them, on a small image (few rays in all).
      {"reference", {}, 131072, false, 8}});

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
