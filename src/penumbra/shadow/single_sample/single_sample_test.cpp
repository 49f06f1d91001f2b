#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "penumbra/core/rng.h"
#include "penumbra/scene/shapes.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/shadow/single_sample/outer_objects.h"
#include "penumbra/testing/test_scenes.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {

using single_sample::falloff;
using single_sample::sphere_transmission;
using single_sample::triangle_cone_distance;

TEST(SingleSample, SphereFormulaAtChosenPoints) {
  // Ray from the origin straight up to a light of diameter D = 1 at distance 10; sphere
  // of radius 1 at height 5: t0 = 5, b = D t0 / |l - o| = 0.5.
  Vec3f o(0, 0, 0), v(0, 1, 0);
  auto s = [&](float d) { return sphere_transmission(o, v, 10.0f, {d, 5, 0}, 1.0f, 1.0f); };
  EXPECT_EQ(s(0.0f), 0.0f);   // the ray hits the sphere
  EXPECT_EQ(s(0.99f), 0.0f);  // still inside R
  // tau = (d - R) / b; s = 3 tau^2 - 2 tau^3
  EXPECT_NEAR(s(1.1f), 3 * 0.04f - 2 * 0.008f, 1e-5f);  // tau = 0.2 -> 0.104
  EXPECT_NEAR(s(1.25f), 0.5f, 1e-5f);                   // tau = 0.5
  EXPECT_NEAR(s(1.4f), 3 * 0.64f - 2 * 0.512f, 1e-5f);  // tau = 0.8 -> 0.896
  EXPECT_EQ(s(1.6f), 1.0f);                             // outside the outer sphere
  // Behind the point (t0 < 0) or beyond the light: no shadow.
  EXPECT_EQ(sphere_transmission(o, v, 10.0f, {0, -3, 0}, 1.0f, 1.0f), 1.0f);
  EXPECT_EQ(sphere_transmission(o, v, 10.0f, {0, 12, 0}, 1.0f, 1.0f), 1.0f);
}

TEST(SingleSample, TransmissionIsContinuousAcrossBothBoundaries) {
  Vec3f o(0, 0, 0), v(0, 1, 0);
  auto s = [&](float d) { return sphere_transmission(o, v, 10.0f, {d, 5, 0}, 1.0f, 1.0f); };
  for (float boundary : {1.0f, 1.5f}) {
    EXPECT_NEAR(s(boundary - 1e-4f), s(boundary + 1e-4f), 1e-3f) << boundary;
  }
  // And the slope is zero at both ends (the cubic's point): s changes by O(eps^2).
  // (tau = 0.02 at both: 3 tau^2 = 1.2e-3.)
  EXPECT_LT(s(1.0f + 1e-2f), 1.5e-3f);
  EXPECT_GT(s(1.5f - 1e-2f), 1.0f - 1.5e-3f);
  // Monotone in between.
  float prev = 0;
  for (float d = 1.0f; d <= 1.5f; d += 0.01f) {
    float x = s(d);
    EXPECT_GE(x, prev - 1e-6f);
    prev = x;
  }
  EXPECT_NEAR(single_sample::inverse_falloff(falloff(0.3f)), 0.3f, 1e-5f);
}

TEST(SingleSample, TriangleConeDistanceIsTheSmallestPerspectiveOffset) {
  // Brute force: the minimum of perp / t over a dense barycentric grid of the triangle
  // (points with near <= t <= far) approaches the computed value from above.
  Rng rng(17);
  for (int trial = 0; trial < 50; ++trial) {
    Vec3f o(0, 0, 0);
    Vec3f v = normalize(Vec3f(rng.next_float() - 0.5f, 1.0f, rng.next_float() - 0.5f));
    Vec3f e1, e2;
    coordinate_system(v, &e1, &e2);
    auto rnd = [&] { return Vec3f(4 * rng.next_float() - 2, 4 * rng.next_float() - 0.5f, 4 * rng.next_float() - 2); };
    Vec3f a = rnd(), b = rnd(), c = rnd();
    const float near = 0.01f, far = 3.0f;
    float computed = triangle_cone_distance(o, v, e1, e2, near, far, a, b, c);
    float brute = kInfinity;
    const int n = 300;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        Vec3f x = a + (b - a) * (float(i) / n) + (c - a) * (float(j) / n);
        float t = dot(x, v);
        if (t < near || t > far) continue;
        brute = std::min(brute, length(x - v * t) / t);
      }
    if (!std::isfinite(brute)) {
      // No grid point in range; the exact answer may still see a sliver.
      continue;
    }
    EXPECT_LE(computed, brute + 1e-5f) << trial;
    EXPECT_NEAR(computed, brute, 0.02f * (1 + brute)) << trial;
  }
}

// Penumbra width on the ground across the shadow edge of `occluder`, at x, sampling z from
// +0.1 down every 0.5 mm: from the last fully dark sample to the first fully lit one.
float penumbra_width(const Scene& scene, float x) {
  RayTracer tracer(scene);
  auto method = create_method("single-sample", scene, {});
  ShadowContext ctx;
  ctx.scene = &scene;
  ctx.light = &scene.lights[0];
  ctx.tracer = &tracer;
  method->prepare(ctx);
  ViewSamples vs;
  const int n = 2400;
  for (int i = 0; i < n; ++i) {
    ViewSample s;
    s.p = {x, 0, 0.1f - 0.0005f * i};
    s.ng = s.ns = {0, 1, 0};
    vs.samples.push_back(s);  // object 0 (the ground), prim 0
  }
  std::vector<float> vis(n);
  ShadowOutput out{vis, {}};
  method->evaluate(ctx, vs, out);
  int last_dark = -1;
  for (int i = 0; i < n; ++i)
    if (vis[i] == 0.0f) last_dark = i;
  if (last_dark < 0) return -1.0f;
  for (int i = last_dark; i < n; ++i)
    if (vis[i] >= 1.0f) return vs.samples[last_dark].p.z - vs.samples[i].p.z;
  return -1.0f;
}

// A horizontal plate at height h over z in [0, 4] casts a shadow whose edge lies along
// z = 0 under a light centred above that edge. parker1998's outer object has width
// b = D t / |l - o| at the occluder; on the ground that is W = D h / (H - h): zero at
// contact, linear in h while h << H.
TEST(SingleSample, PenumbraGrowsLinearlyWithDistanceFromTheOccluder) {
  const float H = 4.0f;
  const float D = 2.0f * std::sqrt(1.0f / kPi);  // equal-area diameter of the 1 x 1 light
  for (float h : {0.05f, 0.1f, 0.2f, 0.4f, 0.8f}) {
    Scene scene = testing::ground_scene({testing::object(testing::quad_y(h, -4, 4, 0, 4))},
                                        testing::rect_light_down({0, H, 0}, 1.0f, 1.0f));
    float w = penumbra_width(scene, 0.3f);
    float expected = D * h / (H - h);
    EXPECT_NEAR(w, expected, 0.03f * expected + 0.001f) << "h = " << h;
  }
}

// A ramp touching the ground along x = 0 and rising to height 1 at x = 2: its shadow's
// side edge is sharp where it touches the ground.
TEST(SingleSample, PenumbraIsZeroWhereTheOccluderTouchesTheReceiver) {
  TriangleMesh ramp;
  ramp.positions = {{0, 0, 0}, {2, 1, 0}, {2, 1, 4}, {0, 0, 4}};
  ramp.indices = {0, 2, 1, 0, 3, 2};
  Scene scene = testing::ground_scene({testing::object(ramp)}, testing::rect_light_down({0, 4, 0}, 1.0f, 1.0f));
  float at_contact = penumbra_width(scene, 0.002f);
  float farther = penumbra_width(scene, 0.8f);
  EXPECT_GE(at_contact, 0.0f);
  EXPECT_LE(at_contact, 0.001f);  // two sampling steps
  EXPECT_GT(farther, 0.05f);
}

TEST(SingleSample, CombinationRulesOfTwoOccluders) {
  // Two analytic spheres beside the ray, each alone letting through s1 and s2.
  auto sphere_object = [](Vec3f c, float r) {
    // An octahedron inscribed in the sphere for Embree (never hit here: the ray passes
    // outside the sphere), and the analytic sphere for parker1998's formula.
    SceneObject o = testing::object(TriangleMesh{});
    o.mesh.positions = {c + Vec3f(r, 0, 0), c - Vec3f(r, 0, 0), c + Vec3f(0, r, 0),
                        c - Vec3f(0, r, 0), c + Vec3f(0, 0, r), c - Vec3f(0, 0, r)};
    o.mesh.indices = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    o.sphere = SphereShape{c, r};
    return o;
  };
  AreaLight light = testing::rect_light_down({0, 8, 0}, 1.0f, 1.0f);
  Scene scene = testing::ground_scene({sphere_object({0.56f, 2, 0}, 0.5f), sphere_object({-0.65f, 5, 0}, 0.3f)}, light);
  const float D = 2.0f * std::sqrt(1.0f / kPi);  // equal-area diameter of the 1 x 1 light
  Vec3f o = offset_ray_origin({0, 0, 0}, {0, 1, 0}, {0, 1, 0});
  float dist = 8.0f - o.y;
  float s1 = sphere_transmission(o, {0, 1, 0}, dist, {0.56f, 2, 0}, 0.5f, D);
  float s2 = sphere_transmission(o, {0, 1, 0}, dist, {-0.65f, 5, 0}, 0.3f, D);
  ASSERT_GT(s1, 0.05f);
  ASSERT_LT(s1, 0.95f);
  ASSERT_GT(s2, 0.05f);
  ASSERT_LT(s2, 0.95f);
  RayTracer tracer(scene);
  ViewSamples vs;
  ViewSample p;
  p.p = {0, 0, 0};
  p.ng = p.ns = {0, 1, 0};
  vs.samples = {p};
  for (auto [mode, expected] : {std::pair{"min", std::min(s1, s2)}, std::pair{"multiply", s1 * s2},
                                std::pair{"add", std::max(0.0f, 1 - ((1 - s1) + (1 - s2)))}}) {
    auto m = create_method("single-sample", scene, {std::string("combine=") + mode});
    ShadowContext ctx;
    ctx.scene = &scene;
    ctx.light = &scene.lights[0];
    ctx.tracer = &tracer;
    m->prepare(ctx);
    float vis = -1;
    ShadowOutput out{std::span<float>(&vis, 1), {}};
    m->evaluate(ctx, vs, out);
    EXPECT_NEAR(vis, expected, 1e-4f) << mode;
  }
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

// V of single-sample (with `params`) at the given receivers of `scene`.
std::vector<float> single_sample_v(const Scene& scene, const ViewSamples& vs, const std::vector<std::string>& params) {
  RayTracer tracer(scene);
  auto method = create_method("single-sample", scene, params);
  ShadowContext ctx;
  ctx.scene = &scene;
  ctx.light = &scene.lights[0];
  ctx.tracer = &tracer;
  method->prepare(ctx);
  std::vector<float> vis(vs.size(), -1.0f);
  ShadowOutput out{vis, {}};
  method->evaluate(ctx, vs, out);
  return vis;
}

// Ground receivers (object 0, normal +y) on an n x n grid over [-half, half]^2, in
// scanline order like a camera pass.
ViewSamples ground_grid(int n, float half) {
  ViewSamples vs;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      ViewSample s;
      s.p = {-half + 2 * half * (i + 0.5f) / n, 0.0f, -half + 2 * half * (j + 0.5f) / n};
      s.ng = s.ns = {0, 1, 0};
      s.object = 0;
      s.prim = 0;
      vs.samples.push_back(s);
    }
  return vs;
}

TEST(SingleSample, ContourCandidatesMatchTheAllTriangleSearchOnAClosedMesh) {
  SceneObject ball = testing::object(make_uv_sphere(0.5f, 48));
  ball.mesh.transform(Mat4::translate({0.2f, 0.9f, -0.1f}));
  Scene scene = testing::ground_scene({ball}, testing::rect_light_down({-0.5f, 3.0f, 0.3f}, 1.0f, 1.0f));
  ASSERT_TRUE(scene.objects[1].closed);
  ViewSamples vs = ground_grid(160, 2.0f);
  std::vector<float> contour = single_sample_v(scene, vs, {"candidates=contour"});
  std::vector<float> all = single_sample_v(scene, vs, {"candidates=all"});
  double sum = 0, worst = 0;
  int penumbra = 0;
  for (size_t k = 0; k < vs.size(); ++k) {
    double d = std::abs(contour[k] - all[k]);
    sum += d;
    worst = std::max(worst, d);
    penumbra += all[k] > 0.0f && all[k] < 1.0f;
  }
  std::printf("contour vs all on %zu ground points (%d in the penumbra): mean |dV| %.2e, max %.2e\n", vs.size(),
              penumbra, sum / vs.size(), worst);
  for (int b = 0; b < 10; ++b) {
    double bs = 0, bw = 0, bsigned = 0; int bn = 0;
    for (size_t k = 0; k < vs.size(); ++k) {
      if (all[k] <= 0.0f || all[k] >= 1.0f) continue;
      if (int(all[k] * 10) != b) continue;
      double d = contour[k] - all[k];
      bs += std::abs(d); bsigned += d; bw = std::max(bw, std::abs(d)); ++bn;
    }
    std::printf("  V in [%.1f, %.1f): n %d mean |dV| %.4f signed %.4f max %.4f\n", b / 10.0, (b + 1) / 10.0, bn, bn ? bs / bn : 0, bn ? bsigned / bn : 0, bw);
  }
  ASSERT_GT(penumbra, 2000);
  EXPECT_LT(sum / vs.size(), 1e-3);
  EXPECT_LT(worst, 0.05);
}

}  // namespace
}  // namespace penumbra
