#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "penumbra/core/rng.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene/shapes.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/shadow/single_sample/outer_objects.h"
#include "penumbra/testing/memory_cases.h"
#include "penumbra/testing/test_scenes.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

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

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

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

// A closed UV sphere (a mesh, not parker1998's analytic sphere) floating over the ground,
// the ground sampled densely around its shadow.
Scene floating_ball_scene() {
  SceneObject ball = testing::object(make_uv_sphere(0.5f, 48));
  ball.mesh.transform(Mat4::translate({0.2f, 0.9f, -0.1f}));
  return testing::ground_scene({ball}, testing::rect_light_down({-0.5f, 3.0f, 0.3f}, 1.0f, 1.0f));
}

// With band = 1 the candidate set holds every triangle on the contour seen from any
// point within D of the light centre, which includes the contour seen from every receiver
// whose ray passes within the outer object: the minimum is the all-triangle minimum.
TEST(SingleSample, ContourBandOfOneIsExactOnAClosedMesh) {
  Scene scene = floating_ball_scene();
  ASSERT_TRUE(scene.objects[1].closed);
  ViewSamples vs = ground_grid(160, 2.0f);
  std::vector<float> band = single_sample_v(scene, vs, {"candidates=contour", "band=1", "neighbours=false"});
  std::vector<float> all = single_sample_v(scene, vs, {"candidates=all"});
  int penumbra = 0;
  for (size_t k = 0; k < vs.size(); ++k) {
    penumbra += all[k] > 0.0f && all[k] < 1.0f;
    ASSERT_NEAR(band[k], all[k], 1e-5f) << k;
  }
  EXPECT_GT(penumbra, 5000);
}

// The default contour set (band = 0): the contour seen from the light centre instead of
// from each receiver. Exact where the ray grazes the mesh (tau -> 0), a subset elsewhere,
// so never darker; the error grows toward the outer edge of the penumbra (the numbers in
// docs/methods/single-sample.md), and a wider band shrinks it.
TEST(SingleSample, ContourCandidatesApproximateTheAllTriangleSearch) {
  Scene scene = floating_ball_scene();
  ViewSamples vs = ground_grid(160, 2.0f);
  std::vector<float> all = single_sample_v(scene, vs, {"candidates=all"});
  auto errors = [&](const std::vector<float>& v, double* mean, double* worst, double* worst_dark) {
    double sum = 0;
    int n = 0;
    *worst = *worst_dark = 0;
    for (size_t k = 0; k < vs.size(); ++k) {
      EXPECT_GE(v[k], all[k] - 1e-6f) << k;  // a subset of the triangles: never darker
      if (!(all[k] > 0.0f && all[k] < 1.0f)) {
        EXPECT_NEAR(v[k], all[k], 1e-6f) << k;  // umbra and fully lit agree
        continue;
      }
      double d = std::abs(v[k] - all[k]);
      sum += d;
      ++n;
      *worst = std::max(*worst, d);
      if (all[k] < 0.1f) *worst_dark = std::max(*worst_dark, d);
    }
    *mean = sum / std::max(1, n);
  };
  double mean0, worst0, dark0, mean5, worst5, dark5;
  errors(single_sample_v(scene, vs, {"band=0", "neighbours=false"}), &mean0, &worst0, &dark0);
  errors(single_sample_v(scene, vs, {"band=0.5", "neighbours=false"}), &mean5, &worst5, &dark5);
  std::printf("contour vs all in the penumbra: band 0: mean |dV| %.4f max %.4f (V < 0.1: %.4f); band 0.5: %.4f %.4f\n",
              mean0, worst0, dark0, mean5, worst5);
  EXPECT_LT(dark0, 0.01);  // tau small: the two contours nearly coincide
  EXPECT_LT(mean0, 0.03);
  EXPECT_LT(worst0, 0.1);
  EXPECT_LT(mean5, 0.5 * mean0);
  EXPECT_LE(worst5, worst0);
}

// scenes/contact.json: the box stands on the ground. A vertical silhouette edge of the box
// (seen from the light centre L) casts a shadow edge that starts at the box's foot C and
// runs away from the light; the point of the edge at height h shadows the ground at
// G(h) = L' + (C - L') Ly / (Ly - h) (L' = L on the ground). A ground point offset by u
// from there, perpendicular to the shadow edge, sees its ray to L pass the edge line at
// d = u (Ly - h) / Ly, at t along the ray (A to L, t / A = h / Ly). Along the edge, a
// point dz higher is sqrt(d^2 + dz^2 sin^2 a) off the ray at t + dz cos a (a: the angle
// between the edge and the ray, tan a = |L' - G| / Ly), so the smallest perp / t is
// q / sqrt(1 + q^2 / tan^2 a) with q = d / t. V reaches falloff(tau) when that is tau k
// (k = D / A), at
//   u(h) = tau D h / (Ly - h) / sqrt(1 - (tau k / tan a)^2),
// zero where the box touches the ground and growing linearly with h near it. Measured to
// V = 0.1: beyond the edge's own penumbra V rises slowly as the whole edge and the lit
// wall next to it stay near the rim of the wide cone (V ~ 0.2 to 0.7 here), so the V = 1
// end of the penumbra is no measure of the edge.
TEST(SingleSample, ContactShadowWidthOnContactScene) {
  Scene scene = load_scene(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/contact.json");
  // The ball's outer object would overlap the box's penumbra on one side: measure the box alone.
  std::erase_if(scene.objects, [](const SceneObject& o) { return o.name == "ball"; });
  scene.finalize();
  size_t box_index = 0;
  for (size_t i = 0; i < scene.objects.size(); ++i)
    if (scene.objects[i].name == "box") box_index = i;
  ASSERT_GT(box_index, 0u);
  const AreaLight& light = scene.lights[0];
  const Vec3f L = light.center;
  const float D = 2.0f * std::sqrt(light.area() / kPi);  // equal-area diameter (the default)
  // The box's foot corners (y = 0), and the two that bound its shadow: extreme in angle
  // around the light's ground point.
  std::vector<Vec3f> feet;
  for (Vec3f p : scene.objects[box_index].mesh.positions)
    if (std::abs(p.y) < 1e-5f && std::none_of(feet.begin(), feet.end(), [&](Vec3f q) { return length(q - p) < 1e-5f; }))
      feet.push_back(p);
  ASSERT_EQ(feet.size(), 4u);
  const Vec3f Lg(L.x, 0.0f, L.z);
  Vec3f mid(0.0f);
  for (Vec3f f : feet) mid += f * 0.25f;
  auto angle = [&](Vec3f p) {
    Vec3f a = normalize(mid - Lg), d = p - Lg;
    return std::atan2(a.x * d.z - a.z * d.x, a.x * d.x + a.z * d.z);
  };
  std::sort(feet.begin(), feet.end(), [&](Vec3f a, Vec3f b) { return angle(a) < angle(b); });
  int measured = 0;
  auto sqr = [](float x) { return x * x; };
  for (Vec3f C : {feet.front(), feet.back()}) {
    const Vec3f d = normalize(C - Lg);  // along the shadow edge, away from the light
    Vec3f p(-d.z, 0.0f, d.x);           // across it, pointing out of the shadow
    if (dot(p, C - mid) < 0) p = -p;
    ++measured;
    for (float h : {0.005f, 0.05f, 0.1f, 0.2f, 0.3f}) {
      const Vec3f G = Lg + (C - Lg) * (L.y / (L.y - h));
      const float step = 2.5e-4f;
      ViewSamples vs;
      for (int i = 0; i < 4000; ++i) {
        ViewSample s;
        s.p = G + p * (-0.05f + step * i);
        s.ng = s.ns = {0, 1, 0};
        vs.samples.push_back(s);  // the ground: object 0
      }
      std::vector<float> v = single_sample_v(scene, vs, {});
      int last_dark = -1, level = -1;
      for (int i = 0; i < 4000; ++i)
        if (v[i] == 0.0f) last_dark = i;
      for (int i = std::max(0, last_dark); i < 4000 && level < 0; ++i)
        if (v[i] >= 0.1f) level = i;
      ASSERT_GE(last_dark, 0) << "h = " << h;
      ASSERT_GT(level, 0) << "h = " << h;
      // The hard shadow edge is where G(h) says (to the 3e-5 ray offset and the step).
      EXPECT_NEAR(-0.05f + step * last_dark, 0.0f, 2 * step) << "h = " << h;
      const float width = step * (level - last_dark);
      const float tau = single_sample::inverse_falloff(0.1f);
      const float k = D / length(L - G), tan_a = length(Lg - G) / L.y;
      const float expected = tau * D * h / (L.y - h) / std::sqrt(1 - sqr(tau * k / tan_a));
      EXPECT_NEAR(width, expected, 0.05f * expected + 2 * step) << "corner " << C.x << "," << C.z << " h = " << h;
    }
  }
  EXPECT_EQ(measured, 2);
}

// Packets of 4 or 8 rays (SIMD) find the same minimum as one ray at a time.
TEST(SingleSample, PacketsGiveTheSameVisibilityAsSingleRays) {
  Scene scene = load_scene(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/knot.json");
  scene.camera.width = scene.camera.height = 96;
  RayTracer tracer(scene);
  ViewSamples vs = camera_pass(scene, tracer, 0);
  for (const char* neighbours : {"neighbours=false", "neighbours=true"}) {
    std::vector<float> one = single_sample_v(scene, vs, {"packet=1", neighbours});
    for (const char* packet : {"packet=4", "packet=8"}) {
      std::vector<float> v = single_sample_v(scene, vs, {packet, neighbours});
      for (size_t k = 0; k < vs.size(); ++k)
        ASSERT_NEAR(v[k], one[k], 1e-5f) << packet << " " << neighbours << " sample " << k;
    }
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// The memory-estimate checks (render/memory_estimate_test.cpp, testing/memory_cases.h): what
// each estimate must grow with, and a case whose maps dominate the heap.
const testing::MemoryCaseRegistration kSingleSampleMemory(
    "single-sample", {"triangles", "leaf_size"},
    {// What grows with the triangles: the BVH of the outer objects.
      {"single-sample", {"candidates=all"}, 4, /*many_triangles=*/true}});

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
