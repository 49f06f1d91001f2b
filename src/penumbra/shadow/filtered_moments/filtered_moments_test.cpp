// vsm, evsm and msm: the moment arithmetic against closed forms (Chebyshev's bound for one
// planar occluder, light bleeding where theory puts it, the 4-moment Hamburger bound from an
// independently computed three-point quadrature), the prefiltered maps on synthetic depth
// maps, and the methods on small scenes against `reference` and `shadow-map`.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "penumbra/core/error.h"
#include "penumbra/eval/metrics.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/filtered_moments/filtered_moments.h"
#include "penumbra/shadow/filtered_moments/filtered_moments_shared.h"
#include "penumbra/shadow/filtered_moments/models.h"
#include "penumbra/testing/gpu_method_runs.h"
#include "penumbra/testing/memory_cases.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra::filtered_moments {
namespace {
namespace PENUMBRA_UNITY_ID {

using penumbra::testing::ground_scene;
using penumbra::testing::object;
using penumbra::testing::quad_y;
using penumbra::testing::rect_light_down;

// A w x h depth map whose column x holds depth_of(x) (linear depths; +inf = empty).
template <class F>
DepthMap columns_map(int w, int h, F depth_of) {
  DepthMap m;
  m.resize(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) m.z[m.index(x, y)] = depth_of(x);
  return m;
}

// ---------------------------------------------------------------------------------------
// VSM: Chebyshev's bound (Donnelly & Lauritzen 2006)

// One planar occluder over a planar receiver: columns [0, 16) at the occluder's depth 2,
// the rest at the receiver's depth 3 (normalised: a = 0.05 and c = 0.95). A box with
// fraction f of occluder texels has mean mu = f a + (1 - f) c and variance
// f (1 - f) (c - a)^2, so for every t the filtered moments give Chebyshev's bound
// sigma^2 / (sigma^2 + (t - mu)^2) in closed form, and at the receiver (t = c) exactly
// 1 - f: VSM is exact for one planar occluder.
TEST(VsmChebyshev, OnePlanarOccluderGivesTheClosedFormBound) {
  const DepthMap map = columns_map(64, 32, [](int x) { return x < 16 ? 2.0f : 3.0f; });
  const VsmModel model(/*min_variance=*/0, /*bleeding=*/0);
  FilteredMomentMap fm;
  fm.build(map, model, Prefilter::Sat);
  const double a = fm.normalize(2.0f), c = fm.normalize(3.0f);
  EXPECT_NEAR(a, FilteredMomentMap::kNear, 1e-12);
  EXPECT_NEAR(c, FilteredMomentMap::kFar, 1e-12);
  for (double x0 : {6.0, 10.5, 12.25, 15.0}) {
    const double x1 = x0 + 8;  // 8 texels wide, around the occluder's edge at x = 16
    const double f = std::clamp((16 - x0) / 8, 0.0, 1.0);
    double m[2];
    fm.mean(x0, 4, x1, 20, m);
    const double mu = f * a + (1 - f) * c, var = f * (1 - f) * (c - a) * (c - a);
    EXPECT_NEAR(m[0], mu, 1e-7);  // the texels are floats
    EXPECT_NEAR(m[1] - m[0] * m[0], var, 1e-6);
    for (double t : {0.3, 0.6, 0.9, c}) {
      const double expected = t <= mu ? 1.0 : var / (var + (t - mu) * (t - mu));
      EXPECT_NEAR(model.visibility(m, t), expected, 1e-5) << "x0 " << x0 << " t " << t;
    }
    EXPECT_NEAR(model.visibility(m, c), 1 - f, 1e-5);
    // The blocker estimate of Yang et al. 2010 finds the occluder exactly.
    const BlockerEstimate b = model.blockers(m, c, 0);
    EXPECT_NEAR(b.fraction, f, 1e-5);
    if (f > 0) EXPECT_NEAR(b.depth, a, 1e-4);
  }
}

// Two occluders at different depths over a receiver behind both (normalised depths a < b
// < c): a box half over each occluder is fully shadowed (V = 0), but the bound is
// sigma^2 / (sigma^2 + (t - mu)^2) with mu = (a + b) / 2, sigma^2 = (b - a)^2 / 4: for
// linear depths 2, 3, 4 (normalised 0.05, 0.65, 0.95) 0.2 at t = c: light bleeding. Over the
// far occluder alone the receiver is dark (no bleeding); the reduction's linstep with
// bleeding >= 0.2 removes it and leaves lit boxes lit.
TEST(VsmBleeding, AppearsWhereTheoryPutsItAndTheReductionRemovesIt) {
  // Columns: [0, 16) near occluder (2), [16, 32) far occluder (3), [32, 64) receiver (4).
  const DepthMap map = columns_map(64, 16, [](int x) { return x < 16 ? 2.0f : x < 32 ? 3.0f : 4.0f; });
  const VsmModel plain(0, 0), reduced(0, 0.25f);
  FilteredMomentMap fm;
  fm.build(map, plain, Prefilter::Sat);
  double both[2], far_only[2], receiver[2];
  fm.mean(8, 2, 24, 14, both);      // half near, half far occluder
  fm.mean(18, 2, 30, 14, far_only);  // the far occluder alone
  fm.mean(40, 2, 60, 14, receiver);  // the lit receiver
  const double a = fm.normalize(2.0f), b = fm.normalize(3.0f), t = fm.normalize(4.0f - 1e-3f);
  const double mu = 0.5 * (a + b), var = 0.25 * (b - a) * (b - a);
  EXPECT_NEAR(plain.visibility(both, t), var / (var + (t - mu) * (t - mu)), 1e-5);
  EXPECT_GT(plain.visibility(both, t), 0.19f);  // bleeding
  EXPECT_LT(plain.visibility(far_only, t), 1e-3f);
  EXPECT_EQ(reduced.visibility(both, t), 0.0f);
  EXPECT_EQ(reduced.visibility(far_only, t), 0.0f);
  EXPECT_EQ(reduced.visibility(receiver, t), 1.0f);
  EXPECT_EQ(plain.visibility(receiver, t), 1.0f);
  // The bound decreases as the receiver moves away from the occluders: the bleeding is
  // worst right behind the far occluder (t just beyond b).
  EXPECT_GT(plain.visibility(both, 0.6), plain.visibility(both, 0.9));
}

// ---------------------------------------------------------------------------------------
// EVSM (Lauritzen & McCool 2008)

// The bleeding configuration above: the warps shrink the bound toward the truth (0) as the
// exponent grows, the 4-component form at least as well as the 2-component one.
TEST(EvsmExponents, LargeExponentsRemoveTheBleedingAndApproachTheDepthTest) {
  const DepthMap map = columns_map(64, 64, [](int x) { return x < 16 ? 2.0f : x < 32 ? 3.0f : 4.0f; });
  float last = 1;
  for (float c : {1.0f, 5.0f, 10.0f, 20.0f, 40.0f}) {
    const EvsmModel two(c, c, false, 0, 0), four(c, c, true, 0, 0);
    FilteredMomentMap fm2, fm4;
    fm2.build(map, two, Prefilter::Sat);
    fm4.build(map, four, Prefilter::Mipmap);
    double m2[4], m4[4];
    const double t = fm2.normalize(4.0f - 1e-3f);
    fm2.mean(8, 2, 24, 14, m2);
    fm4.mean(0, 0, 32, 32, m4);  // the 32 x 32 mip square over both occluders (and padding)
    const float v2 = two.visibility(m2, t);
    EXPECT_LT(v2, last) << c;
    EXPECT_LE(four.visibility(m4, t), std::max(v2, 1e-6f) * 1.0001f + 1e-6f) << c;
    last = v2;
  }
  EXPECT_LT(last, 1e-6f);
  // And lit stays lit: the receiver region, and the occluders seen from in front of them.
  const EvsmModel model(40, 5, true, 1e-6f, 0);
  FilteredMomentMap fm;
  fm.build(map, model, Prefilter::Mipmap);
  double m[4];
  fm.mean(40, 0, 56, 16, m);
  EXPECT_NEAR(model.visibility(m, fm.normalize(4.0f - 1e-3f)), 1.0f, 1e-5);
  fm.mean(0, 0, 16, 16, m);
  EXPECT_NEAR(model.visibility(m, fm.normalize(1.9f)), 1.0f, 1e-5);
}

// ---------------------------------------------------------------------------------------
// MSM: the Hamburger 4MSM bound (Peters & Klein 2015)

// The sharp lower bound on the fraction in front of zf, computed here independently of
// moments.cpp: the biased Hankel matrix inverted by its adjugate, the kernel polynomial's
// roots by the quadratic formula, the weights by Cramer's rule on the Vandermonde system of
// moments 0..2. Also checks that this quadrature reproduces moments 3 and 4 (so it is the
// canonical representation through zf).
double independent_hamburger(std::array<double, 4> raw, double zf, double alpha) {
  double b[5] = {1, 0, 0, 0, 0};
  for (int i = 0; i < 4; ++i) b[i + 1] = (1 - alpha) * raw[i] + alpha * 0.5;
  const double H[3][3] = {{b[0], b[1], b[2]}, {b[1], b[2], b[3]}, {b[2], b[3], b[4]}};
  const double det = H[0][0] * (H[1][1] * H[2][2] - H[1][2] * H[2][1]) -
                     H[0][1] * (H[1][0] * H[2][2] - H[1][2] * H[2][0]) +
                     H[0][2] * (H[1][0] * H[2][1] - H[1][1] * H[2][0]);
  double inv[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      // Cofactor of H[j][i].
      const int r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3, c1 = (i + 2) % 3;
      inv[i][j] = (H[r0][c0] * H[r1][c1] - H[r0][c1] * H[r1][c0]) / det;
    }
  const double v[3] = {1, zf, zf * zf};
  double c[3];
  for (int i = 0; i < 3; ++i) c[i] = inv[i][0] * v[0] + inv[i][1] * v[1] + inv[i][2] * v[2];
  const double disc = c[1] * c[1] - 4 * c[2] * c[0];
  const double z[3] = {zf, (-c[1] - std::sqrt(disc)) / (2 * c[2]), (-c[1] + std::sqrt(disc)) / (2 * c[2])};
  // Vandermonde V w = (1, b1, b2), V[k][i] = z_i^k, by Cramer's rule.
  auto det3 = [](const double m[3][3]) {
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  };
  double V[3][3];
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 3; ++i) V[k][i] = std::pow(z[i], k);
  const double dv = det3(V);
  double w[3];
  for (int i = 0; i < 3; ++i) {
    double Vi[3][3];
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < 3; ++j) Vi[k][j] = j == i ? b[k] : V[k][j];
    w[i] = det3(Vi) / dv;
  }
  for (int k = 3; k <= 4; ++k) {
    double m = 0;
    for (int i = 0; i < 3; ++i) m += w[i] * std::pow(z[i], k);
    EXPECT_NEAR(m, b[k], 1e-9) << "the quadrature does not reproduce moment " << k;
  }
  double lower = 0;
  for (int i = 1; i < 3; ++i)
    if (z[i] < zf) lower += w[i];
  return lower;
}

std::array<double, 4> power_moments_of(std::initializer_list<std::pair<double, double>> depth_weight) {
  std::array<double, 4> b{};
  for (auto [z, w] : depth_weight)
    for (int k = 0; k < 4; ++k) b[k] += w * std::pow(z, k + 1);
  return b;
}

TEST(MsmHamburger, EqualsTheIndependentThreePointQuadrature) {
  const double alpha = 3e-5;
  // Two stacked planes (depths 0.3 and 0.7, weights w and 1 - w) and a three-depth mix.
  for (double w : {0.1, 0.35, 0.5, 0.8}) {
    for (auto raw : {power_moments_of({{0.3, w}, {0.7, 1 - w}}),
                     power_moments_of({{0.2, w / 2}, {0.45, w / 2}, {0.9, 1 - w}})}) {
      for (double zf : {0.25, 0.4, 0.6, 0.75, 0.95}) {
        const MomentQuadrature q = hamburger_4msm(raw, zf, alpha);
        EXPECT_NEAR(q.intensity, std::clamp(independent_hamburger(raw, zf, alpha), 0.0, 1.0), 1e-7)
            << "w " << w << " zf " << zf;
      }
    }
    // Between the two planes the bound is the near plane's weight (up to the moment bias):
    // the sharp lower bound of a two-point distribution is exact.
    const auto two = power_moments_of({{0.3, w}, {0.7, 1 - w}});
    EXPECT_NEAR(hamburger_4msm(two, 0.5, alpha).intensity, w, 2e-3) << w;
    EXPECT_NEAR(hamburger_4msm(two, 0.9, alpha).intensity, 1.0, 2e-3) << w;
    EXPECT_NEAR(hamburger_4msm(two, 0.2, alpha).intensity, 0.0, 2e-3) << w;
    // The moment blocker search (Peters et al. 2016) finds the near plane between them.
    const BlockerEstimate b = moment_blockers(two, 0.5, alpha);
    EXPECT_NEAR(b.fraction, w, 2e-3);
    EXPECT_NEAR(b.depth, 0.3, 2e-3);
  }
}

TEST(MsmQuantization, TheOptimizedBasisStaysInTheUnitCubeAndRoundTrips) {
  for (int i = 0; i <= 100; ++i) {
    const double z = i / 100.0, z2 = z * z;
    const std::array<double, 4> b = {z, z2, z2 * z, z2 * z2};
    const std::array<double, 4> q = msm_optimize(b);
    for (double v : q) {
      EXPECT_GE(v, -1e-6) << z;
      EXPECT_LE(v, 1 + 1e-6) << z;
    }
    const std::array<double, 4> back = msm_deoptimize(q);
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(back[k], b[k], 1e-9) << z;
  }
}

// Two stacked planes in a synthetic map, filtered over a box of known weights and stored in
// 16 bits: the lookup gives 1 - the independent Hamburger bound of the mixed moments, within
// the quantisation error, and the bound is the truth (1 - w) between the planes.
TEST(MsmFiltered, TwoStackedPlanesGiveTheClosedFormBound) {
  // Columns [0, 20): the near plane at 2; [20, 64): the far plane at 4 (normalised 0 and 1).
  const DepthMap map = columns_map(64, 16, [](int x) { return x < 20 ? 2.0f : 4.0f; });
  for (bool quantize : {false, true}) {
    const MsmModel model(3e-5f, quantize, 0);
    FilteredMomentMap fm;
    fm.build(map, model, Prefilter::Sat);
    for (double x0 : {11.0, 14.5, 17.0}) {
      const double w = (20 - x0) / 10;  // a 10-texel box
      double m[4];
      fm.mean(x0, 3, x0 + 10, 13, m);
      const auto raw = power_moments_of({{fm.normalize(2.0f), w}, {fm.normalize(4.0f), 1 - w}});
      const double zf = fm.normalize(3.0f);  // between the planes
      const double tolerance = quantize ? 2e-3 : 1e-5;
      EXPECT_NEAR(model.visibility(m, zf), 1 - independent_hamburger(raw, zf, 3e-5), tolerance) << x0;
      EXPECT_NEAR(model.visibility(m, zf), 1 - w, 2e-3 + tolerance) << x0;
    }
  }
}

// ---------------------------------------------------------------------------------------
// The methods on scenes

Image render_v(const Scene& scene, const std::string& method, std::vector<std::string> params = {}, int spp = 16) {
  RenderSettings settings;
  settings.method = method;
  settings.params = std::move(params);
  settings.light_samples = spp;
  return render_scene(scene, settings).visibility;
}

int count(const Image& v, const std::function<bool(size_t)>& pred) {
  int n = 0;
  for (size_t i = 0; i < v.pixel_count(); ++i) n += pred(i);
  return n;
}

// Light, occluder and receiver in parallel planes: the blocker search finds the occluder's
// depth, the filter is the light's rectangle projected through the receiver onto it (the
// exact visibility integral for a rect light, as for pcss), and the bound is exact for one
// planar occluder (VsmChebyshev above). So vsm and msm agree with ray tracing up to texels.
TEST(VsmScene, ExactForOneOccluderParallelToTheLight) {
  Scene scene = ground_scene({object(quad_y(1.0f, -0.4f, 0.4f, -0.3f, 0.5f))}, rect_light_down({0, 2, 0}, 1.0f, 0.6f), 48);
  scene.camera = penumbra::testing::top_camera(48, 4.0f, 45.0f);
  const Image ref = render_v(scene, "reference", {}, 256);
  EXPECT_GT(count(ref, [&](size_t i) { return ref.data()[i] > 0.1f && ref.data()[i] < 0.9f; }), 48 * 48 / 20);
  for (const char* method : {"vsm", "msm", "evsm"}) {
    const Image v = render_v(scene, method, {"resolution=512", "near_field=0"});
    const ErrorStats e = compare_images(v, ref);
    std::printf("[ numbers  ] %s one parallel occluder: MAE %.4f, max %.3f\n", method, e.mae, e.max_abs);
    EXPECT_LT(e.mae, 0.005) << method;
    EXPECT_LT(e.max_abs, 0.05) << method;
  }
}

// Two occluders at different depths over the ground, the upper one hiding part of the lower
// one from the light's centre, the light off to the side so that the camera above sees the
// ground in their combined umbra. With a fixed filter and one estimate over it (the papers'
// set-up, so that the only error is the moments'; subdivide=1) as wide as the occluders'
// overlap, the filter regions there hold
// both occluders' depths and the ground behind: VSM lets light through (bleeding,
// VsmBleeding above); the reduction, EVSM's warps and MSM's four moments remove nearly all
// of it.
TEST(VsmScene, BleedingUnderStackedOccludersAndItsReduction) {
  std::vector<SceneObject> occ;
  occ.push_back(object(quad_y(1.3f, -0.3f, 0.5f, -0.5f, 0.5f)));    // upper
  occ.push_back(object(quad_y(0.5f, -0.6f, 0.2f, -0.45f, 0.45f)));  // lower
  Scene scene = ground_scene(std::move(occ), rect_light_down({1.2f, 2, 0}, 0.8f, 0.8f), 48);
  scene.camera = penumbra::testing::top_camera(48, 4.0f, 60.0f);
  const Image ref = render_v(scene, "reference", {}, 256);
  auto bleeding = [&](const std::string& method, std::vector<std::string> extra) {
    std::vector<std::string> p = {"resolution=256", "blocker_search=false", "filter_size=24", "subdivide=1",
                                  "near_field=0"};
    p.insert(p.end(), extra.begin(), extra.end());
    const Image v = render_v(scene, method, p);
    return count(v, [&](size_t i) { return ref.data()[i] < 0.02f && v.data()[i] > 0.05f; });
  };
  const int umbra = count(ref, [&](size_t i) { return ref.data()[i] < 0.02f; });
  const int plain = bleeding("vsm", {});
  const int reduced = bleeding("vsm", {"bleeding=0.5"});
  const int evsm = bleeding("evsm", {});
  const int msm = bleeding("msm", {});
  std::printf("[ numbers  ] umbra pixels %d; bleeding into them: vsm %d, vsm bleeding=0.5 %d, evsm %d, msm %d\n", umbra,
              plain, reduced, evsm, msm);
  EXPECT_GT(umbra, 100);
  EXPECT_GT(plain, umbra / 10);
  EXPECT_LT(reduced, plain / 4);
  EXPECT_LT(evsm, plain / 4);
  EXPECT_LT(msm, plain / 4);
}

// A small scene with a box standing on the ground (contact) and a floating square.
Scene small_scene(int res) {
  std::vector<SceneObject> occluders;
  occluders.push_back(object(quad_y(0.5f, -0.7f, -0.1f, -0.3f, 0.3f)));
  occluders.push_back(object(penumbra::testing::box({0.3f, 0, -0.2f}, {0.6f, 0.7f, 0.2f})));
  Scene s = ground_scene(std::move(occluders), rect_light_down({0, 2, 0}, 1.0f, 1.0f), res);
  s.camera = penumbra::testing::top_camera(res, 4.0f, 40.0f);
  return s;
}

// Each method against the ground truth on the small scene (tolerances: docs/methods/vsm.md,
// msm.md; what is left is contact shadows and the box's overlapping blockers).
TEST(VsmScene, EveryFilteredMethodIsCloseToTheReference) {
  const Scene scene = small_scene(48);
  const Image ref = render_v(scene, "reference", {}, 256);
  for (const char* method : {"vsm", "evsm", "msm"}) {
    const ErrorStats e = compare_images(render_v(scene, method, {"resolution=512"}), ref);
    std::printf("[ numbers  ] %s small scene: MAE %.4f, RMSE %.4f\n", method, e.mae, e.rmse);
    EXPECT_LT(e.mae, 0.015) << method;
  }
}

// The search and filter regions split into parts (subdivide, fm_parts): on the bunny, whose
// regions over the ears and the back hold the bunny's own surfaces in front of a receiver and the
// ground behind it, each method comes closer to the ground truth than with one estimate per
// region (measured at 64², 64 against 256 samples: vsm 0.0228 -> 0.0166, evsm 0.0282 ->
// 0.0150, msm 0.0240 -> 0.0155).
TEST(VsmScene, RegionsSplitIntoPartsBleedLessOnTheBunny) {
  const Scene bunny = penumbra::testing::shipped_scene("bunny.json", 64);
  const Image ref = render_v(bunny, "reference", {}, 256);
  for (const char* method : {"vsm", "evsm", "msm"}) {
    const double one = compare_images(render_v(bunny, method, {"subdivide=1", "near_field=0"}, 64), ref).mae;
    const double parts = compare_images(render_v(bunny, method, {"near_field=0"}, 64), ref).mae;
    std::printf("[ numbers  ] %s bunny 64²: MAE one estimate %.4f, in parts %.4f\n", method, one, parts);
    EXPECT_LT(parts, 0.85 * one) << method;
  }
}

// The parts of a region tile it: their outer sides are the region's own bit for bit (one part is
// the region), neighbours share their sides, and there is one part per two texels up to the cap.
TEST(VsmScene, PartsTileTheRegion) {
  using shader::fm_part_box;
  using shader::fm_parts;
  EXPECT_EQ(fm_parts(0.5, 4), 1);
  EXPECT_EQ(fm_parts(1.0, 4), 1);
  EXPECT_EQ(fm_parts(1.5, 4), 2);
  EXPECT_EQ(fm_parts(3.2, 4), 4);
  EXPECT_EQ(fm_parts(100.0, 4), 4);
  EXPECT_EQ(fm_parts(100.0, 1), 1);
  const double cx = 517.3, cy = 12.9, hx = 7.7, hy = 0.3;
  const shader::FmBox whole = fm_part_box(cx, cy, hx, hy, 0, 0, 1, 1);
  EXPECT_EQ(whole.x0, cx - hx);
  EXPECT_EQ(whole.x1, cx + hx);
  EXPECT_EQ(whole.y0, cy - hy);
  EXPECT_EQ(whole.y1, cy + hy);
  const int nx = 3, ny = 4;
  double area = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const shader::FmBox r = fm_part_box(cx, cy, hx, hy, i, j, nx, ny);
      if (i == 0) EXPECT_EQ(r.x0, cx - hx);
      if (i == nx - 1) EXPECT_EQ(r.x1, cx + hx);
      if (j == 0) EXPECT_EQ(r.y0, cy - hy);
      if (j == ny - 1) EXPECT_EQ(r.y1, cy + hy);
      if (i > 0) EXPECT_EQ(r.x0, fm_part_box(cx, cy, hx, hy, i - 1, j, nx, ny).x1);
      if (j > 0) EXPECT_EQ(r.y0, fm_part_box(cx, cy, hx, hy, i, j - 1, nx, ny).y1);
      area += (r.x1 - r.x0) * (r.y1 - r.y0);
    }
  EXPECT_NEAR(area, 4 * hx * hy, 1e-9);
}

// EVSM with a point-like light and a one-texel filter at the largest exponents is the plain
// shadow map (the depth test) up to the map's texels.
// The near field (fm_near_field_length, docs/methods/vsm.md "The near field"): the plant's leaves,
// a few millimetres to centimetres above one another. A leaf's filter region mixes the leaves above
// it with the surfaces behind it, and the moments let light through (too bright); with the light
// centre's ray traced where an occluder's penumbra would be narrower than two texels, each method
// comes closer to the ground truth and less too bright.
TEST(VsmScene, TheNearFieldDarkensLeavesUnderLeavesAsTheReferenceDoes) {
  const Scene scene = penumbra::testing::shipped_scene("plant.json", 48);
  const Image ref = render_v(scene, "reference", {}, 512);
  for (const char* method : {"vsm", "evsm", "msm"}) {
    const ErrorStats alone = compare_images(render_v(scene, method, {"near_field=0"}), ref);
    const ErrorStats near = compare_images(render_v(scene, method, {}), ref);
    std::printf("[ numbers  ] %s plant 48²: MAE %.4f (signed %+.4f) alone, %.4f (%+.4f) with the near field\n",
                method, alone.mae, alone.mean_signed, near.mae, near.mean_signed);
    EXPECT_LT(near.mae, 0.85 * alone.mae) << method;
    EXPECT_LT(near.mean_signed, alone.mean_signed - 0.002) << method;
  }
  // The statistic: no rays without a near field.
  RenderSettings settings;
  settings.method = "vsm";
  const RenderResult r = render_scene(scene, settings);
  EXPECT_GT(r.stats.extra.at("near_field_rays").get<uint64_t>(), 48u * 48u / 10);
  settings.params = {"near_field=0"};
  EXPECT_EQ(render_scene(scene, settings).stats.extra.at("near_field_rays").get<uint64_t>(), 0u);
}

// Which view samples trace the near field's ray, and how far (both devices' function).
TEST(VsmNearField, LengthIsTheMapsNearFieldWhereTheMapLetsLightThrough) {
  shader::FmShadeBlock b{};
  b.map.view.eye = Vec3f(0, 2, 0);
  b.map.view.forward = Vec3f(0, -1, 0);
  b.map.view.l = -1;
  b.map.view.r = 1;
  b.map.view.width = 100;
  b.map.view.near = 1;
  b.near_field = 8;
  b.light_width = 0.5f;
  const Vec3f p(0.2f, 0, 0.1f), up(0, 1, 0);
  const float expected = shader::sm_near_field_length(b.map, p, 8, 0.5f);
  EXPECT_GT(expected, 0.0f);
  EXPECT_EQ(shader::fm_near_field_length(b, p, up, /*closed=*/false, 0.5f), expected);
  EXPECT_EQ(shader::fm_near_field_length(b, p, up, /*closed=*/true, 0.5f), expected);
  EXPECT_EQ(shader::fm_near_field_length(b, p, up, false, 0.0f), 0.0f);  // the map says dark
  EXPECT_EQ(shader::fm_near_field_length(b, p, -up, false, 0.5f), expected);  // an open surface's back
  EXPECT_EQ(shader::fm_near_field_length(b, p, -up, true, 0.5f), 0.0f);  // a solid hides the centre
  b.near_field = 0;
  EXPECT_EQ(shader::fm_near_field_length(b, p, up, false, 0.5f), 0.0f);
  // Texels of 2 cm at the near plane (depth 1) are 4 cm at p's depth 2: 8 of them resolve 0.32, so
  // the ray is traced for 0.32 D / (0.5 + 0.32) of the D to the light's centre.
  const float seg = length(b.map.view.eye - p);
  EXPECT_NEAR(expected, 0.32f * seg / (0.5f + 0.32f), 1e-4f);
}

TEST(EvsmScene, LargeExponentsAndATinyLightGiveTheShadowMap) {
  Scene scene = small_scene(64);
  scene.lights[0].size = scene.lights[0].size * 1e-4f;
  const Image sm = render_v(scene, "shadow-map", {"resolution=512"});
  // (The largest exponents need the mip chain: a summed-area table loses their moments.)
  const Image ev = render_v(scene, "evsm",
                            {"resolution=512", "prefilter=mipmap", "positive_exponent=42", "negative_exponent=42",
                             "near_field=0"});
  EXPECT_LE(fraction_above(ev, sm, 0.5), 0.02);
  EXPECT_GT(count(sm, [&](size_t i) { return sm.data()[i] < 0.5f; }), 64 * 64 / 40);
}

TEST(EvsmParams, BadComponentsNameTheKey) {
  const Scene scene = small_scene(8);
  try {
    render_v(scene, "evsm", {"components=3"});
    ADD_FAILURE() << "rendered";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("components"), std::string::npos) << e.what();
  }
}

TEST(MsmRegistration, FlagsAndEstimates) {
  for (const char* name : {"vsm", "evsm", "msm"}) {
    const MethodInfo& info = MethodRegistry::get(name);
    EXPECT_FALSE(info.samples_light) << name;
    EXPECT_FALSE(info.tile_exact) << name;  // the map is fitted to the view samples
    ASSERT_TRUE(info.estimate_memory) << name;
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::filtered_moments

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// The memory-estimate checks (render/memory_estimate_test.cpp, testing/memory_cases.h): what
// each estimate must grow with, and a case whose maps dominate the heap.
const testing::MemoryCaseRegistration kVsmMemory(
    "vsm", {"resolution", "triangles"},
    {{"vsm", {"resolution=1024"}}});
const testing::MemoryCaseRegistration kEvsmMemory(
    "evsm", {"resolution", "components", "triangles"},
    {{"evsm", {"resolution=1024"}}});
const testing::MemoryCaseRegistration kMsmMemory(
    "msm", {"resolution", "triangles"},
    {{"msm", {"resolution=1024"}}});

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
