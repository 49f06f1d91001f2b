#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "penumbra/core/error.h"
#include "penumbra/core/rng.h"
#include "penumbra/shadow/denoised/atrous_filter.h"
#include "penumbra/shadow/shadow_rays.h"
#include "penumbra/testing/memory_cases.h"
#include "penumbra/testing/method_runs.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using namespace penumbra::testing;

// A w x h image of one fronto-parallel plane (constant depth, normal toward the camera).
denoise::GuidedImage plane_image(int w, int h, float depth = 2.0f) {
  denoise::GuidedImage img;
  img.resize(w, h);
  for (size_t i = 0; i < img.valid.size(); ++i) {
    img.valid[i] = 1;
    img.depth[i] = depth;
    img.normal[i] = {0, 0, 1};
  }
  return img;
}

TEST(RtDenoisedFilter, ConstantVisibilityStaysConstant) {
  // V = S / U = 0.37 everywhere, with U (the unshadowed estimate), the variance, the depth
  // and the normal varying: the ratio of the filtered estimates is V again.
  denoise::GuidedImage img = plane_image(40, 30);
  Rng rng(5);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const size_t i = img.index(x, y);
      img.depth[i] = 2.0f + 0.01f * x + 0.02f * y;
      img.normal[i] = normalize(Vec3f(0.1f * rng.next_float(), 0.1f * rng.next_float(), 1.0f));
      img.unshadowed[i] = 0.5f + rng.next_float();
      img.shadowed[i] = 0.37f * img.unshadowed[i];
      img.variance[i] = 0.05f * rng.next_float();
    }
  img.valid[img.index(3, 4)] = 0;  // a hole (background) changes nothing
  denoise::atrous_filter(img, {});
  for (size_t i = 0; i < img.valid.size(); ++i)
    if (img.valid[i]) ASSERT_NEAR(img.ratio(i), 0.37f, 1e-5f) << i;
}

TEST(RtDenoisedFilter, NearIdentityWhereVisibilityIsSmoothAndWellSampled) {
  // A smooth V (a slow wave) whose per-pixel variance is that of many samples: the luminance
  // weight stops the blur at differences of a few standard deviations, V moves little.
  denoise::GuidedImage img = plane_image(48, 48);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const size_t i = img.index(x, y);
      img.unshadowed[i] = 1.0f;
      img.shadowed[i] = 0.5f + 0.4f * std::sin(0.2f * x) * std::cos(0.15f * y);
      img.variance[i] = 0.25f / 4096;  // binary T, 4096 samples
    }
  const denoise::GuidedImage before = img;
  denoise::atrous_filter(img, {});
  float worst = 0;
  for (size_t i = 0; i < img.valid.size(); ++i) worst = std::max(worst, std::abs(img.ratio(i) - before.ratio(i)));
  double mean = 0;
  for (size_t i = 0; i < img.valid.size(); ++i) mean += std::abs(img.ratio(i) - before.ratio(i));
  mean /= img.valid.size();
  std::printf("smooth V, 4096-sample variance: max |dV| %.5f, mean %.5f\n", worst, mean);
  EXPECT_LT(worst, 0.02f);
  EXPECT_LT(mean, 0.005);
}

// Two regions of the image: the left half V ~ 0.9 +- 0.1, the right V ~ 0.1 +- 0.1, noisy
// enough that the luminance weight lets everything through; the guides separate them.
denoise::GuidedImage two_regions(bool by_depth) {
  denoise::GuidedImage img = plane_image(32, 24);
  Rng rng(9);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const size_t i = img.index(x, y);
      const bool left = x < img.width / 2;
      if (by_depth) img.depth[i] = left ? 1.0f : 3.0f;
      else img.normal[i] = left ? Vec3f(0, 0, 1) : Vec3f(1, 0, 0);
      img.unshadowed[i] = 1.0f;
      img.shadowed[i] = (left ? 0.8f : 0.0f) + 0.2f * rng.next_float();
      img.variance[i] = 1.0f;
    }
  return img;
}

TEST(RtDenoisedFilter, NeverCrossesADepthOrNormalDiscontinuity) {
  for (bool by_depth : {true, false}) {
    SCOPED_TRACE(by_depth ? "depth" : "normal");
    denoise::GuidedImage img = two_regions(by_depth);
    denoise::atrous_filter(img, {});
    double left = 0, right = 0;
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) {
        const float v = img.ratio(img.index(x, y));
        // A convex combination of its own side's values only.
        if (x < img.width / 2) ASSERT_GE(v, 0.8f - 1e-5f) << x << "," << y;
        else ASSERT_LE(v, 0.2f + 1e-5f) << x << "," << y;
        (x < img.width / 2 ? left : right) += v;
      }
    // And it did filter: both sides are smoothed toward their means.
    EXPECT_NEAR(left / (img.width / 2 * img.height), 0.9, 0.02);
    EXPECT_NEAR(right / (img.width / 2 * img.height), 0.1, 0.02);
  }
  // Without the guides (one plane), the halves do mix.
  denoise::GuidedImage img = plane_image(32, 24);
  const denoise::GuidedImage split = two_regions(true);
  img.shadowed = split.shadowed;
  img.unshadowed = split.unshadowed;
  img.variance = split.variance;
  denoise::atrous_filter(img, {});
  EXPECT_LT(img.ratio(img.index(15, 12)), 0.8f);
}

// The fan sums of n light samples drawn as `reference` draws them (seed 1234), per view sample:
// the irradiance ratio sum T f / sum f (the area fraction where sum f is 0) and the area fraction
// sum T a / sum a (`reference`'s V).
struct FanTruth {
  std::vector<float> ratio, area;
};
FanTruth fan_truth(const SceneRun& r, int n, uint64_t seed = 1234) {
  ShadowContext ctx;
  ctx.scene = &r.scene;
  ctx.light = &r.scene.lights[0];
  ctx.tracer = r.tracer.get();
  ctx.seed = seed;
  FanTruth t{std::vector<float>(r.vs.size()), std::vector<float>(r.vs.size())};
  trace_light_fans(ctx, r.vs, n, LightSampling::SolidAngle, [&](size_t k, const LightFan& fan) {
    double s = 0, f = 0, sa = 0, a = 0;
    for (int i = 0; i < fan.count; ++i) {
      s += fan.transmittance[i] * fan.irradiance[i];
      f += fan.irradiance[i];
      sa += fan.transmittance[i] * fan.area_weight[i];
      a += fan.area_weight[i];
    }
    const float area = a > 0 ? static_cast<float>(sa / a) : 0.0f;
    t.ratio[k] = f > 0 ? static_cast<float>(s / f) : area;
    t.area[k] = area;
  });
  return t;
}

// Mean |dV|, compare's headline error (docs/compare.md).
double mean_abs_error(const std::vector<float>& a, const std::vector<float>& b) {
  double s = 0;
  for (size_t k = 0; k < a.size(); ++k) s += std::abs(a[k] - b[k]);
  return s / a.size();
}

TEST(RtDenoisedScenes, LowerErrorThanTheUnfilteredEstimateAtTheSameSamples) {
  const SceneRun r = load_scene_at("contact", 64);
  const std::vector<float> truth = fan_truth(r, 256).area;
  for (int samples : {1, 4}) {
    SCOPED_TRACE(samples);
    const std::string n = "samples=" + std::to_string(samples);
    const double filtered = mean_abs_error(run_method(r, "rt-denoised", 0, {n}), truth);
    // iterations=0: the same samples, unfiltered (the ratio estimator alone); `reference`
    // at --spp = samples draws the very same samples too (its V: the area fraction).
    const double unfiltered = mean_abs_error(run_method(r, "rt-denoised", 0, {n, "iterations=0"}), truth);
    const double reference = mean_abs_error(run_method(r, "reference", samples), truth);
    std::printf("contact 64x64, %d samples: mean |dV| filtered %.4f, unfiltered %.4f, reference %.4f\n", samples,
                filtered, unfiltered, reference);
    EXPECT_LT(filtered, 0.75 * unfiltered);
    EXPECT_LT(filtered, 0.75 * reference);
  }
}

// Which V and which E: unfiltered (iterations=0), V is the area fraction of the pixel's own
// samples (`reference`'s V: the contact scene's box faces whose tangent plane cuts the light see
// part of it) and E is the irradiance ratio of the same samples times the closed-form unshadowed
// irradiance (Heitz et al. 2018: the colour), each the fan's own sums.
TEST(RtDenoisedScenes, VIsTheAreaFractionAndEIsTheRatioTimesTheUnshadowedIrradiance) {
  const SceneRun r = load_scene_at("contact", 48);
  const int n = 8;
  const FanTruth truth = fan_truth(r, n, 7);
  auto m = create_method("rt-denoised", r.scene, {"samples=8", "iterations=0"});
  ASSERT_TRUE(m->computes_irradiance());
  ShadowContext ctx;
  ctx.scene = &r.scene;
  ctx.light = &r.scene.lights[0];
  ctx.tracer = r.tracer.get();
  ctx.seed = 7;
  m->prepare(ctx);
  std::vector<float> v(r.vs.size(), -1.0f);
  std::vector<Vec3f> e(r.vs.size());
  ShadowOutput out{v, e};
  m->evaluate(ctx, r.vs, out);
  const AreaLight& light = r.scene.lights[0];
  int differ = 0;
  for (size_t k = 0; k < r.vs.size(); ++k) {
    const ViewSample& s = r.vs.samples[k];
    ASSERT_NEAR(v[k], std::clamp(truth.area[k], 0.0f, 1.0f), 1e-6f) << k;
    const Vec3f e0 = light.radiance * light.unshadowed_irradiance_scalar(s.p, s.ns);
    const Vec3f want = e0 * std::clamp(truth.ratio[k], 0.0f, 1.0f);
    ASSERT_NEAR(e[k].x, want.x, 1e-5f * (1 + std::abs(want.x))) << k;
    differ += std::abs(truth.area[k] - truth.ratio[k]) > 0.05f;
  }
  // The two are different quantities on this scene (the box's faces, the cosine's weights).
  EXPECT_GT(differ, 20);
}

TEST(RtDenoisedScenes, SameSeedSameImage) {
  const SceneRun r = load_scene_at("contact", 32);
  const std::vector<float> a = run_method(r, "rt-denoised", 0, {"samples=2"}, nullptr, 7);
  EXPECT_EQ(a, run_method(r, "rt-denoised", 0, {"samples=2"}, nullptr, 7));
  EXPECT_NE(a, run_method(r, "rt-denoised", 0, {"samples=2"}, nullptr, 8));
  for (float v : a) ASSERT_TRUE(v >= 0 && v <= 1);
}

TEST(RtDenoisedScenes, BadParameterNamesTheKey) {
  const SceneRun r = load_scene_at("contact", 8);
  for (const char* bad : {"samples=9", "samples=0", "iterations=-1", "sigma_l=0"}) {
    try {
      run_method(r, "rt-denoised", 0, {bad});
      ADD_FAILURE() << bad << " accepted";
    } catch (const Error& e) {
      const std::string key = std::string(bad).substr(0, std::string(bad).find('='));
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// The memory-estimate checks (render/memory_estimate_test.cpp, testing/memory_cases.h).
const testing::MemoryCaseRegistration kRtDenoisedMemory(
    "rt-denoised", {},
    {// The guided image per pixel, on a large image. Its estimate grows with the view samples
     // alone (its 1-8 light samples fit one padded fan).
     {"rt-denoised", {}, 4, false, 512}});

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
