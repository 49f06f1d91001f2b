#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>

#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"
#include "penumbra/raster/raster_triangle.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/lam/attenuation_map.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/testing/gpu_method_runs.h"
#include "penumbra/testing/memory_cases.h"
#include "penumbra/testing/method_runs.h"
#include "penumbra/testing/test_scenes.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using namespace penumbra::testing;

// A square-ish occluder at height h covering x in [-1.5, 0] (the edge at x = 0) over the
// ground, under a w x w rect light at height H centred above the edge.
constexpr float kH = 2.0f, kh = 1.0f, kw = 1.0f;

Scene edge_scene() {
  return ground_scene({object(quad_y(kh, -1.5f, 0.0f, -1.0f, 1.0f))}, rect_light_down({0, kH, 0}, kw, kw));
}

// The exact V of a ground point (x, 0, z) under the edge: the part of the light with
// lx >= -x (H - h) / h is visible.
float analytic_v(float x) { return clamp01(0.5f + x * (kH - kh) / (kh * kw)); }

ViewSamples ground_line(float x0, float x1, int n, float z = 0.0137f) {
  ViewSamples vs;
  vs.width = n;
  vs.height = 1;
  for (int i = 0; i < n; ++i) {
    ViewSample s;
    s.p = {x0 + (x1 - x0) * (i + 0.5f) / n, 0.0f, z};
    s.ng = s.ns = {0, 1, 0};
    s.albedo = Vec3f(0.8f);
    s.pixel = static_cast<uint32_t>(i);
    vs.samples.push_back(s);
  }
  return vs;
}

std::vector<float> run_lam(const Scene& scene, const ViewSamples& vs, int spp, std::vector<std::string> params,
                           MethodStats* stats = nullptr) {
  auto m = create_method("lam", scene, params);
  RayTracer tracer(scene);
  ShadowContext ctx;
  ctx.scene = &scene;
  ctx.light = &scene.lights[0];
  ctx.tracer = &tracer;
  ctx.light_samples = spp;
  m->prepare(ctx);
  std::vector<float> v(vs.size(), -1.0f);
  std::vector<Vec3f> e(vs.size());
  ShadowOutput out{v, e};
  m->evaluate(ctx, vs, out);
  if (stats) *stats = m->stats();
  return v;
}

// The attenuation map of a scene's first light, built directly (the method's filter is
// fixed at construction; one map serves both lookups here).
lam::AttenuationMap build_map(const Scene& scene, int spp, int resolution = 512) {
  const RasterTriangles tris = gather_raster_triangles(scene);
  const ShadowRegion region = fit_shadow_region(scene, scene.lights[0]);
  const LightSampleSet set(spp, 7, /*per_pixel=*/false);
  lam::BuildOptions opt;
  opt.resolution = resolution;
  return lam::build_attenuation_map(tris, scene.lights[0], region, set.base(), opt);
}

std::vector<float> lookup_all(const lam::AttenuationMap& map, const ViewSamples& vs, lam::Filter filter) {
  std::vector<float> v(vs.size(), -1.0f);
  map.visibility(vs.samples, v, filter);
  // The single-point lookup agrees with the batch.
  for (size_t i = 0; i < vs.size(); i += 17) EXPECT_EQ(map.visibility(vs.samples[i].p, vs.samples[i].ng, filter), v[i]);
  return v;
}

constexpr lam::Filter kFilters[] = {lam::Filter::Nearest, lam::Filter::Bilinear};
const char* name(lam::Filter f) { return f == lam::Filter::Nearest ? "nearest" : "bilinear"; }

TEST(Lam, Eq3WarpEqualsTheProjectiveWarp) {
  Rng rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    AreaLight light = rect_light_down({rng.next_float() - 0.5f, 3.0f, rng.next_float() - 0.5f},
                                      0.5f + rng.next_float(), 0.5f + rng.next_float());
    light.frame = Frame::from_zx(normalize(Vec3f(rng.next_float() - 0.5f, -1.0f, rng.next_float() - 0.5f)),
                                 {1, 0, 0});
    const LightAxes axes = light_axes(light);
    ShadowRegion region;
    region.empty = false;
    region.u0 = -0.6f; region.u1 = 0.5f; region.v0 = -0.4f; region.v1 = 0.7f;
    region.near = 1.0f; region.far = 5.0f;
    const LightView ref = lam::reference_view(axes, region, 256);
    // The axes are the view's.
    EXPECT_NEAR(length(ref.right() - axes.right), 0.0f, 1e-6f);
    EXPECT_NEAR(length(ref.up() - axes.up), 0.0f, 1e-6f);
    const float delta = ref.texel_world_size(1.0f);
    for (int s = 0; s < 8; ++s) {
      Vec3f q = light.sample_area(rng.next_2d());
      int ox = 0, oy = 0;
      const LightView sv = lam::sample_view(axes, ref, q, &ox, &oy);
      Vec3f d = q - axes.eye;
      for (int k = 0; k < 50; ++k) {
        // A random point of the region, seen from the sample at (x, y, z).
        float z = 1.0f + 4.0f * rng.next_float();
        Vec3f p = ref.texel_to_world({rng.next_float() * ref.width(), rng.next_float() * ref.height()}, z);
        Vec3f t = sv.to_texel(p);
        ASSERT_NEAR(t.z, z, 1e-4f * z);
        // Inside the widened sample view.
        EXPECT_GE(t.x, 0.0f);
        EXPECT_LT(t.x, static_cast<float>(sv.width()));
        EXPECT_GE(t.y, 0.0f);
        EXPECT_LT(t.y, static_cast<float>(sv.height()));
        Vec2f w = lam::warp_to_reference({t.x, t.y}, t.z, dot(d, axes.right), dot(d, axes.up), ox, oy, delta);
        Vec3f r = ref.to_texel(p);
        EXPECT_NEAR(w.x, r.x, 2e-3f);
        EXPECT_NEAR(w.y, r.y, 2e-3f);
      }
    }
  }
}

TEST(Lam, FlatOccluderGivesTheAnalyticPenumbraWithinTheBanding) {
  const Scene scene = edge_scene();
  const ViewSamples vs = ground_line(-1.0f, 1.0f, 400);
  for (int spp : {64, 256}) {
    int cols = 0, rows = 0;
    stratification_grid(spp, &cols, &rows);
    // 2.4 cm texels at 256^2: 42 across the 1 m penumbra.
    const lam::AttenuationMap map = build_map(scene, spp, 256);
    for (lam::Filter f : kFilters) {
      const char* filter = name(f);
      std::vector<float> v = lookup_all(map, vs, f);
      double mae = 0, worst = 0;
      for (size_t i = 0; i < vs.size(); ++i) {
        float err = std::abs(v[i] - analytic_v(vs.samples[i].p.x));
        mae += err;
        worst = std::max<double>(worst, err);
      }
      mae /= vs.size();
      // The light samples' x coordinates fall in `cols` strata: a fixed set deviates from
      // the continuous fraction by at most one stratum (1 / cols); the splat and the texel
      // grid add up to a texel's worth of the ramp (2.4% at 256^2). (Measured: worst 0.053 /
      // 0.043 at 64 samples, 0.037 / 0.028 at 256, nearest / bilinear.)
      EXPECT_LE(worst, 1.0 / cols + 0.03) << spp << " " << filter;
      EXPECT_LE(mae, 0.5 / cols) << spp << " " << filter;
      // Umbra and full light exactly.
      EXPECT_EQ(v.front(), 0.0f);
      EXPECT_EQ(v.back(), 1.0f);
    }
  }
}

// A light far from what it shadows (a sun: 100 m wide, 1 km up; and 1,000 km up, 100 km wide) over
// the same edge. epsilon z was 5 m at 1 km, and the ground 1 m under the occluder read as the
// occluder's own surface: lit (mean error 0.48 over this line until 2026-12-07). Scaled by the
// view's width (depth_tolerance_scale), the tolerance keeps them apart, and it stays above the
// depths' float rounding (scaled_depth_tolerance) at 1,000 km. The views' depth range is the
// scene's (1 m here; at least 2^-16 of the depth), not 1% of the distance, which gave every light
// sample's view the parallax of 10 km at 1,000 km (13 s and 3.3 GB for a 64-sample map of 512
// texels).
TEST(Lam, ALightFarFromTheSceneStillTellsTheGroundFromTheOccluderAboveIt) {
  for (const float H : {1e3f, 1e6f}) {
    const float w = 0.1f * H;
    const Scene scene =
        ground_scene({object(quad_y(kh, -1.5f, 0.0f, -1.0f, 1.0f))}, rect_light_down({0, H, 0}, w, w));
    const float ramp = kh * w / (H - kh);  // the penumbra's width on the ground, 0.1 m
    const ViewSamples vs = ground_line(-2 * ramp, 2 * ramp, 400);
    constexpr int kSpp = 64;
    int cols = 0, rows = 0;
    stratification_grid(kSpp, &cols, &rows);
    const lam::AttenuationMap map = build_map(scene, kSpp, 256);
    EXPECT_LT(map.epsilon(), 0.005f * 0.01f) << H;  // the view is 0.2 degrees wide or less
    EXPECT_GE(map.epsilon(), lam::kMinRelativeTolerance) << H;
    EXPECT_LT(map.view().far() - map.view().near(), 20.0f) << H;  // 1.0 and 15.3 (2^-16 of 10^6)
    for (lam::Filter f : kFilters) {
      const std::vector<float> v = lookup_all(map, vs, f);
      double mae = 0;
      for (size_t i = 0; i < vs.size(); ++i) mae += std::abs(v[i] - clamp01(0.5f + vs.samples[i].p.x / ramp));
      mae /= vs.size();
      // The near light's bound above (measured at 1 km: nearest 0.023, bilinear 0.015; 0.48 before).
      EXPECT_LE(mae, 0.5 / cols) << H << " " << name(f);
      EXPECT_EQ(v.front(), 0.0f) << H << " " << name(f);
      EXPECT_EQ(v.back(), 1.0f) << H << " " << name(f);
    }
  }
}

TEST(Lam, OpenSurfacesCloserThanEpsilonStayApartWithTheOpenTolerance) {
  // An open quad 7 mm above the open ground, under a light 2 m up: the ground beneath its middle
  // is in umbra. Within epsilon (0.005 z: 1 cm) the two are one surface and the ground reads as
  // lit as the quad; open_epsilon (0.002 z: 4 mm) keeps them two layers. (The quad is 4 m wide so
  // that the view holding its shadow is 90 degrees wide: a narrower one scales both tolerances
  // down, depth_tolerance_scale.)
  const Scene scene =
      ground_scene({object(quad_y(0.007f, -2.0f, 2.0f, -2.0f, 2.0f))}, rect_light_down({0, kH, 0}, 0.5f, 0.5f));
  ASSERT_FALSE(scene.objects[0].closed);
  ASSERT_FALSE(scene.objects[1].closed);
  const ViewSamples vs = ground_line(-0.2f, 0.2f, 40, 0.0f);  // object 0: the ground
  EXPECT_EQ(build_map(scene, 64, 256).epsilon(), 0.005f);
  for (const char* open : {"open_epsilon=0.002", "open_epsilon=0.005"}) {
    const std::vector<float> v = run_lam(scene, vs, 64, {"resolution=256", "epsilon=0.005", open});
    double mean = 0;
    for (float x : v) mean += x;
    mean /= v.size();
    if (std::string(open) == "open_epsilon=0.002")
      EXPECT_LT(mean, 0.05) << open;  // in umbra
    else
      EXPECT_GT(mean, 0.5) << open;  // merged with the leaf above: lit
  }
}

// Points the LDI does not resolve (lam.md): where one of a point's 4 texels does not hold its
// surface (the paper's umbra, or lit) or their attenuations differ by more than trace_spread, the
// display traces the LDI's own light samples from the point. On the edge scene with texels 16
// times coarser than the penumbra's test above, the traced points are exactly the fixed samples'
// visibility, the picture is closer to the analytic penumbra than the paper's display, and the
// option `unresolved=umbra` traces nothing.
TEST(Lam, PointsTheTexelsDoNotResolveTakeTheTracedVisibilityOfTheLdisSamples) {
  const Scene scene = edge_scene();
  const ViewSamples vs = ground_line(-1.2f, 1.2f, 480);
  constexpr int kSpp = 64;
  // The LDI's light points, as lam.cpp draws them for run_lam's context (seed 0, light 0), and
  // each view sample's visibility of them through Embree.
  RayTracer tracer(scene);
  ShadowContext ctx;
  ctx.light = &scene.lights[0];
  ctx.light_samples = kSpp;
  const LightSampleSet set = lam::light_sample_set(ctx);
  std::vector<float> x, y, z;
  for (const Vec2f& u : set.base()) {
    const Vec3f d = scene.lights[0].sample_area(u);
    x.push_back(d.x), y.push_back(d.y), z.push_back(d.z);
  }
  std::vector<float> fixed(vs.size());
  for (size_t i = 0; i < vs.size(); ++i) {
    const ViewSample& s = vs.samples[i];
    std::vector<float> dx(kSpp), dy(kSpp), dz(kSpp), t(kSpp);
    for (int k = 0; k < kSpp; ++k) dx[k] = x[k] - s.p.x, dy[k] = y[k] - s.p.y, dz[k] = z[k] - s.p.z;
    tracer.transmittance_fan(s.p, s.ng, dx.data(), dy.data(), dz.data(), kSpp, t.data());
    double lit = 0;
    for (float v : t) lit += v;
    fixed[i] = static_cast<float>(lit / kSpp);
  }
  auto error = [&](const std::vector<float>& v) {
    double e = 0;
    for (size_t i = 0; i < v.size(); ++i) e += std::abs(v[i] - analytic_v(vs.samples[i].p.x));
    return e / static_cast<double>(v.size());
  };
  auto traced = [](const MethodStats& st) { return st.extra.value("traced_samples", uint64_t{0}); };
  MethodStats st_trace, st_umbra, st_all, st_none;
  const std::vector<float> v_trace = run_lam(scene, vs, kSpp, {"resolution=16"}, &st_trace);
  const std::vector<float> v_umbra = run_lam(scene, vs, kSpp, {"resolution=16", "unresolved=umbra"}, &st_umbra);
  run_lam(scene, vs, kSpp, {"resolution=16", "trace_spread=0"}, &st_all);
  run_lam(scene, vs, kSpp, {"resolution=16", "trace_spread=1"}, &st_none);
  size_t exact = 0;
  for (size_t i = 0; i < vs.size(); ++i) exact += std::abs(v_trace[i] - fixed[i]) <= 1e-6f;
  std::printf("edge at 16 texels: %zu of %zu points traced (%zu with trace_spread 0, %zu with 1); mean |V - exact| "
              "%.4f traced, %.4f the paper's display\n",
              static_cast<size_t>(traced(st_trace)), vs.size(), static_cast<size_t>(traced(st_all)),
              static_cast<size_t>(traced(st_none)), error(v_trace), error(v_umbra));
  EXPECT_GT(traced(st_trace), vs.size() / 10);
  EXPECT_GE(exact, traced(st_trace));  // every traced point is the fixed samples' own answer
  EXPECT_GT(st_trace.rays_traced, 0u);
  EXPECT_LE(st_trace.rays_traced, traced(st_trace) * kSpp);
  EXPECT_LT(error(v_trace), 0.5 * error(v_umbra));
  // The paper's display traces nothing; a larger spread traces fewer points, never more.
  EXPECT_EQ(st_umbra.rays_traced, 0u);
  EXPECT_FALSE(st_umbra.extra.contains("traced_samples"));
  EXPECT_GE(traced(st_all), traced(st_trace));
  EXPECT_LE(traced(st_none), traced(st_trace));
}

// Weighted splats (lam_shared.h, "Counting a layer"): under a comb of thin bars the ground sees
// the light through gaps a texel or two wide. The paper's count counts each gap at every texel its
// pixels' 4-texel splats touch, up to 4 times over: the ground reads too bright. Weighted by the
// part of each texel they cover, the splats give the ground truth's visibility.
TEST(Lam, GroundSeenThroughGapsATexelWideIsCountedOncePerGap) {
  std::vector<SceneObject> bars;
  for (int i = 0; i < 60; ++i) {  // bars 2 cm wide every 5 cm at h = 1: 40% of the light blocked
    const float x0 = -1.5f + 0.05f * static_cast<float>(i);
    bars.push_back(object(quad_y(kh, x0, x0 + 0.02f, -1.5f, 1.5f)));
  }
  SceneRun r;
  r.scene = ground_scene(std::move(bars), rect_light_down({0, kH, 0}, kw, kw));
  r.tracer = std::make_unique<RayTracer>(r.scene);
  r.vs = ground_line(-0.3f, 0.3f, 300, 0.05f);
  auto mean_of = [](const std::vector<float>& v) {
    double m = 0;
    for (float x : v) m += x;
    return m / static_cast<double>(v.size());
  };
  const double exact = mean_of(run_method(r, "reference", 1024));  // Embree's rays: the ground truth
  EXPECT_NEAR(exact, 0.6, 0.03);  // the comb's open fraction, the light spanning 10 periods
  // The paper's display (no point traced): what is measured is the splats' count alone.
  const double weighted = mean_of(run_method(r, "lam", 64, {"resolution=256", "unresolved=umbra"}));
  const double counted =
      mean_of(run_method(r, "lam", 64, {"resolution=256", "unresolved=umbra", "weighted_splats=false"}));
  std::printf("comb: ground truth %.4f, weighted splats %.4f, the paper's count %.4f\n", exact, weighted, counted);
  EXPECT_NEAR(weighted, exact, 0.03) << "counted " << counted;
  EXPECT_GT(counted, exact + 0.08) << "the paper's count, weighted " << weighted;
}

TEST(Lam, AttenuationIsMonotoneAndInTheUnitInterval) {
  const Scene scene = edge_scene();
  const ViewSamples vs = ground_line(-1.2f, 1.2f, 600);
  const lam::AttenuationMap map = build_map(scene, 64, 256);
  for (lam::Filter f : kFilters) {
    const char* filter = name(f);
    std::vector<float> v = lookup_all(map, vs, f);
    for (size_t i = 0; i < v.size(); ++i) {
      EXPECT_GE(v[i], 0.0f);
      EXPECT_LE(v[i], 1.0f);
      if (i > 0) EXPECT_GE(v[i], v[i - 1] - 1e-6f) << filter << " at x = " << vs.samples[i].p.x;
    }
  }
}

TEST(Lam, UnoccludedPointsAreFullyLit) {
  // No caster at all: an empty shadow region, V = 1 without any lookup.
  {
    Scene scene = ground_scene({}, rect_light_down({0, kH, 0}, kw, kw));
    EXPECT_TRUE(fit_shadow_region(scene, scene.lights[0]).empty);
    ViewSamples vs = ground_line(-3.5f, 3.5f, 200);
    for (float x : run_lam(scene, vs, 16, {})) EXPECT_EQ(x, 1.0f);
  }
  // A caster whose shadow falls elsewhere: points of the LDI outside the shadow (on the
  // ground around it and on the caster's lit top) see every light sample.
  {
    Scene scene = ground_scene({object(quad_y(kh, 0.5f, 1.0f, -0.25f, 0.25f))}, rect_light_down({0, kH, 0}, kw, kw));
    ASSERT_FALSE(fit_shadow_region(scene, scene.lights[0]).empty);
    const lam::AttenuationMap map = build_map(scene, 64, 256);
    for (lam::Filter f : kFilters) {
      const char* filter = name(f);
      // The shadow covers x in [0.5, 2.5], z in [-1, 1] on the ground; the region (the
      // caster's window grown by the light) reaches x in [0, 3], z in [-1.5, 1.5] there.
      ViewSamples vs = ground_line(0.02f, 0.45f, 100, 0.0f);
      ViewSamples side = ground_line(0.6f, 2.4f, 200, 1.25f);
      ViewSamples top = ground_line(0.52f, 0.98f, 50, 0.1f);
      for (auto& s : top.samples) s.p.y = kh;
      for (const ViewSamples* more : {&side, &top}) vs.samples.insert(vs.samples.end(), more->samples.begin(), more->samples.end());
      const ShadowRegion r = fit_shadow_region(scene, scene.lights[0]);
      EXPECT_NEAR(r.u0, -1.5f, 1e-4f);  // u = -x / z here (the view's right axis is -x)
      EXPECT_NEAR(r.u1, 0.0f, 1e-4f);
      std::vector<float> v = lookup_all(map, vs, f);
      for (size_t i = 0; i < v.size(); ++i) EXPECT_EQ(v[i], 1.0f) << filter << " " << vs.samples[i].p.x;
    }
  }
}

TEST(Lam, SolidsAreDarkWhereTheirOwnPlaneHidesTheLight) {
  // A box on the ground lit from the +x side: its -x face sees none of the light. Points of
  // that face just below the lit top edge lie within epsilon of the top face's layer in the
  // LDI; the closed mesh's own plane still hides the light from them.
  Scene scene = ground_scene({object(box({-0.3f, 0.0f, -0.3f}, {0.3f, 0.6f, 0.3f}))},
                             rect_light_down({1.5f, 2.0f, 0.0f}, 1.0f, 1.0f));
  ASSERT_TRUE(scene.objects[1].closed);
  ViewSamples vs;
  vs.width = 40;
  vs.height = 2;
  for (int i = 0; i < 20; ++i) {
    ViewSample side;
    side.p = {-0.3f, 0.6f - 0.0005f * (i + 1), -0.2f + 0.02f * i};
    side.ng = side.ns = {-1, 0, 0};
    side.object = 1;
    side.pixel = static_cast<uint32_t>(i);
    vs.samples.push_back(side);
  }
  for (int i = 0; i < 20; ++i) {
    ViewSample top;
    top.p = {-0.29f + 0.03f * i, 0.6f, 0.05f};
    top.ng = top.ns = {0, 1, 0};
    top.object = 1;
    top.pixel = static_cast<uint32_t>(20 + i);
    vs.samples.push_back(top);
  }
  std::vector<float> v = run_lam(scene, vs, 64, {});
  for (int i = 0; i < 20; ++i) EXPECT_EQ(v[i], 0.0f) << "side " << i;
  for (int i = 20; i < 40; ++i) EXPECT_EQ(v[i], 1.0f) << "top " << i;

  // The fraction itself: planes through the 1 x 1 light at x = 1.5 + t split it at t.
  const lam::AttenuationMap map = build_map(scene, 16, 64);
  for (float t : {-0.6f, -0.5f, -0.25f, 0.0f, 0.3f, 0.5f, 0.7f}) {
    float expected = clamp01(0.5f - t);  // the part with x > 1.5 + t
    EXPECT_NEAR(map.front_fraction({1.5f + t, 0.3f, 0.1f}, {1, 0, 0}), expected, 1e-5f) << t;
    EXPECT_NEAR(map.front_fraction({1.5f + t, 0.3f, 0.1f}, {-1, 0, 0}), 1 - expected, 1e-5f) << t;
  }
  EXPECT_EQ(map.front_fraction({0, 0, 0}, {0, 0, 0}), 1.0f);
}

TEST(Lam, ShadowRegionIsTheCastersShadowNotTheWholeGround) {
  const Scene scene = edge_scene();
  const ShadowRegion r = fit_shadow_region(scene, scene.lights[0]);
  ASSERT_FALSE(r.empty);
  // The occluder spans u in [-1.5, 0], v in [-1, 1] at depth 1; the light's half-extent
  // 0.5 over depth 1 grows that by 0.5. (The 8 x 8 ground alone casts nothing: the light is
  // above its plane and nothing lies below it.)
  const float span = std::max(r.u1 - r.u0, r.v1 - r.v0);
  EXPECT_NEAR(span, 3.0f, 1e-3f);
  EXPECT_NEAR(r.near, kH - kh, 1e-4f);
  EXPECT_NEAR(r.far, kH, 1e-4f);
}

// Shadows beyond the 76-degree cut of the shadow region (fit_shadow_region's max_tan): the LDI
// holds nothing there, so the display traces those points (lam_beyond_cap); before, they were lit.
TEST(Lam, ShadowsBeyondTheRegionsCutAreTraced) {
  const Scene street = testing::street_beyond_the_cap_scene(48);
  EXPECT_EQ(fit_shadow_region(street, street.lights[0]).cap_tan, 4.0f);
  EXPECT_EQ(fit_shadow_region(edge_scene(), edge_scene().lights[0]).cap_tan, 0.0f);  // nothing cut
  auto render = [&](const std::string& method, std::vector<std::string> params) {
    return render_scene(street, testing::device_settings(method, std::move(params), false, 7, 64));
  };
  const RenderResult truth = render("reference", {}), traced = render("lam", {}), paper = render("lam", {"unresolved=umbra"});
  double shadow = 0;
  for (float v : truth.visibility.data()) shadow += 1 - v;
  const double e_traced = testing::mean_abs_dv(traced.visibility, truth.visibility);
  const double e_paper = testing::mean_abs_dv(paper.visibility, truth.visibility);
  std::printf("street beyond the cut: mean |dV| %.5f traced, %.5f the paper's display (lit beyond the cut)\n", e_traced,
              e_paper);
  EXPECT_GT(shadow / static_cast<double>(truth.visibility.data().size()), 0.005) << "a shadow to find";
  EXPECT_LE(e_traced, 1e-3);
  EXPECT_GT(e_paper, 5 * e_traced);
  EXPECT_GT(traced.stats.extra.at("traced_samples").get<uint64_t>(), 0u);
}

TEST(Lam, CameraChangeReusesTheLdi) {
  Scene scene = edge_scene();
  scene.camera = top_camera(32);
  RenderSettings settings;
  settings.method = "lam";
  settings.light_samples = 16;
  Renderer renderer(scene, settings);
  RenderResult a = renderer.render();
  EXPECT_EQ(a.stats.prepare_count, 1u);
  EXPECT_GT(a.stats.phase("precompute"), 0.0);
  EXPECT_TRUE(a.stats.extra.contains("depth_complexity"));
  uint64_t prepared = a.stats.prepare_count;
  for (float height : {3.0f, 5.0f}) {
    renderer.set_camera(top_camera(48, height, 50.0f));
    RenderResult b = renderer.render();
    prepared += b.stats.prepare_count;
    EXPECT_EQ(b.stats.phase("precompute"), 0.0);
    EXPECT_GT(b.stats.phase("display"), 0.0);
    EXPECT_EQ(b.visibility.width(), 48);
    // The LDI's statistics are reported with every frame.
    EXPECT_TRUE(b.stats.extra.contains("depth_complexity"));
    EXPECT_GT(b.stats.memory_bytes, 0u);
  }
  EXPECT_EQ(prepared, 1u);
}

TEST(Lam, DepthComplexityIsReportedPerSampleCount) {
  const Scene scene = edge_scene();
  MethodStats st;
  run_lam(scene, ground_line(-1, 1, 10), 32, {}, &st);
  const auto& dc = st.extra.at("depth_complexity");
  ASSERT_EQ(dc.size(), 32u);
  double prev = 0;
  for (size_t k = 0; k < dc.size(); ++k) {
    EXPECT_EQ(dc[k].at("samples").get<int>(), static_cast<int>(k + 1));
    double c = dc[k].at("depth_complexity").get<double>();
    // Layers are only ever added, but new non-empty texels can lower the average a little.
    EXPECT_GE(c, 1.0);
    EXPECT_LE(c, 2.5);  // the occluder over the ground: at most two surfaces anywhere
    prev = c;
  }
  EXPECT_GT(prev, 1.0);  // the ground under the occluder's penumbra is a second layer
  EXPECT_GT(st.phase("precompute"), 0.0);
  EXPECT_GT(st.phase("display"), 0.0);
}

TEST(Lam, ResultsDoNotDependOnTheThreadCount) {
  Scene scene = ground_scene({object(box({-0.4f, 0.3f, -0.3f}, {0.2f, 0.9f, 0.4f})),
                              object(quad_y(1.2f, 0.1f, 0.8f, -0.6f, 0.2f))},
                             rect_light_down({0.2f, kH, 0.1f}, 1.2f, 0.8f));
  ViewSamples vs = ground_line(-1.5f, 1.5f, 500, 0.05f);
  std::vector<float> one;
  {
    ThreadLimit limit(1);
    one = run_lam(scene, vs, 32, {});
  }
  std::vector<float> all = run_lam(scene, vs, 32, {});
  EXPECT_EQ(one, all);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// The map cache's record (AttenuationMap::write/read): the map read back gives the very
// lookups of the map written, and a record cut short anywhere reads as nothing.
TEST(Lam, MapRecordReadsBackToTheSameLookupsAndRejectsTruncation) {
  const Scene scene = testing::ground_scene(
      {testing::object(testing::quad_y(kh, -1.5f, 0.0f, -1.0f, 1.0f))}, testing::rect_light_down({0, kH, 0}, kw, kw));
  const lam::AttenuationMap map = build_map(scene, 64, 64);
  std::ostringstream out;
  map.write(out);
  const std::string bytes = out.str();
  lam::AttenuationMap back;
  std::istringstream in(bytes);
  ASSERT_TRUE(back.read(in));
  EXPECT_EQ(back.width(), map.width());
  EXPECT_EQ(back.layer_count(), map.layer_count());
  const ViewSamples vs = ground_line(-1.2f, 1.2f, 300);
  for (lam::Filter f : kFilters) {
    const std::vector<float> a = lookup_all(map, vs, f), b = lookup_all(back, vs, f);
    EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(float))) << name(f);
  }
  for (size_t cut : {size_t{0}, size_t{5}, bytes.size() / 3, bytes.size() - 1}) {
    lam::AttenuationMap partial;
    std::istringstream short_in(bytes.substr(0, cut));
    EXPECT_FALSE(partial.read(short_in)) << cut;
    EXPECT_TRUE(partial.empty());
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
const testing::MemoryCaseRegistration kLamMemory(
    "lam", {"resolution", "max_layers", "triangles"},
    {{"lam", {"resolution=512"}}});

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
