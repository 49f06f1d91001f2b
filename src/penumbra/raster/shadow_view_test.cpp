#include "penumbra/raster/shadow_view.h"

#include <gtest/gtest.h>

#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/testing.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

std::vector<Vec3f> random_points(Vec3f lo, Vec3f hi, int n, uint64_t seed) {
  Rng rng(seed);
  std::vector<Vec3f> out;
  for (int i = 0; i < n; ++i)
    out.push_back({lo.x + (hi.x - lo.x) * rng.next_float(), lo.y + (hi.y - lo.y) * rng.next_float(),
                   lo.z + (hi.z - lo.z) * rng.next_float()});
  return out;
}

TEST(ShadowView, HoldsEveryReceiverWithSquareTexelsAndTheNearPlaneBeforeTheCasters) {
  // A light at y = 3 looking down and a little sideways; receivers on a patch of ground,
  // casters reaching up to y = 2.5.
  const Vec3f eye{0.3f, 3, -0.2f}, dir{0.2f, -1, 0.1f};
  std::vector<Vec3f> receivers = random_points({-1.5f, 0, -0.7f}, {0.9f, 0.4f, 1.3f}, 500, 1);
  Bounds3f casters;
  casters.extend(Vec3f(-4, 0, -4));
  casters.extend(Vec3f(4, 2.5f, 4));
  for (int res : {64, 512, 2048}) {
    ShadowViewFit fit;
    fit.resolution = res;
    LightView v = fit_shadow_view(eye, dir, {0, 0, 1}, receivers, casters, fit);
    EXPECT_EQ(std::max(v.width(), v.height()), res);
    // Square texels: the window's aspect is the image's.
    float aspect = (v.window_right() - v.window_left()) / (v.window_top() - v.window_bottom());
    EXPECT_NEAR(aspect, static_cast<float>(v.width()) / v.height(), 1e-4f * aspect);
    for (Vec3f p : receivers) {
      Vec3f t = v.to_texel(p);
      EXPECT_GE(t.x, 0.0f);
      EXPECT_LT(t.x, static_cast<float>(v.width()));
      EXPECT_GE(t.y, 0.0f);
      EXPECT_LT(t.y, static_cast<float>(v.height()));
      EXPECT_GE(t.z, v.near());
      EXPECT_LE(t.z, v.far());
    }
    // The casters' top (y = 2.5) is 0.5 below the eye: near must not exceed its depth.
    EXPECT_LE(v.near(), 0.5f * dot(normalize(dir), {0, -1, 0}) + 1e-4f);
    // Tight: some receiver lies within a texel of the left and of the right edge.
    float xmin = 1e30f, xmax = -1e30f;
    for (Vec3f p : receivers) {
      xmin = std::min(xmin, v.to_texel(p).x);
      xmax = std::max(xmax, v.to_texel(p).x);
    }
    if (v.width() >= v.height()) {
      EXPECT_LT(xmin, 1.0f);
      EXPECT_GT(xmax, v.width() - 1.0f);
    }
  }
}

TEST(ShadowView, GrazingReceiversAreCappedAtMaxFov) {
  // Receivers running off toward the eye's own plane: without the cap the window would
  // approach 180 degrees.
  const Vec3f eye{0, 1, 0};
  std::vector<Vec3f> receivers;
  for (int i = 0; i <= 100; ++i) receivers.push_back({-50.0f + i, 0, 0.5f});
  ShadowViewFit fit;
  fit.resolution = 256;
  fit.max_fov = 90;
  LightView v = fit_shadow_view(eye, {0, -1, 0}, {0, 0, 1}, receivers, {}, fit);
  // tan(45 deg) = 1 on each side (plus a hair of slack).
  EXPECT_NEAR(v.window_left() / v.near(), -1.0f, 1e-3f);
  EXPECT_NEAR(v.window_right() / v.near(), 1.0f, 1e-3f);
  EXPECT_NEAR(focal_texels(v), 128.0f, 0.1f);
}

TEST(ShadowView, WhereEveryReceiverLiesBeyondMaxFovTheWindowHoldsThem) {
  // A patch of ground 20 to 30 units off to the side of a light 4 above it: 79-83 degrees off
  // the axis, beyond the 120-degree cap. There is nothing inside the cap to keep texels for, so
  // the window holds the patch (it used to be an error).
  const Vec3f eye{0, 4, 0};
  std::vector<Vec3f> receivers;
  for (int i = 0; i <= 10; ++i)
    for (int j = 0; j <= 10; ++j) receivers.push_back({20.0f + i, 0, -5.0f + j});
  ShadowViewFit fit;
  fit.resolution = 256;
  const LightView v = fit_shadow_view(eye, {0, -1, 0}, {0, 0, 1}, receivers, {}, fit);
  for (Vec3f p : receivers) {
    const Vec3f t = v.to_texel(p);
    EXPECT_GE(t.x, 0.0f);
    EXPECT_LT(t.x, static_cast<float>(v.width()));
    EXPECT_GE(t.y, 0.0f);
    EXPECT_LT(t.y, static_cast<float>(v.height()));
  }
  // No wider than it must be: the patch starts 5 (= 20 / 4) to the side of the axis.
  EXPECT_GT(std::max(std::abs(v.window_left()), std::abs(v.window_right())) / v.near(), 7.4f);
  EXPECT_GT(std::min(std::abs(v.window_left()), std::abs(v.window_right())) / v.near(), 4.9f);
}

TEST(ShadowView, ReceiversBeyondMaxFovWithinTheReachStayInTheWindow) {
  // Ground under a light 4 above it, from 2 to 30 units off to its side: the part beyond 6.9 (60
  // degrees off the axis) lies beyond the 120-degree cap. Without a reach the window stops at the
  // cap; with a reach of x/z in [5, 6] (where some caster's shadow falls) it holds the receivers
  // up to 24 units out, and no farther.
  const Vec3f eye{0, 4, 0};
  std::vector<Vec3f> receivers;
  for (int i = 2; i <= 30; ++i) receivers.push_back({static_cast<float>(i), 0, 0});
  ShadowViewFit fit;
  fit.resolution = 256;
  auto covered = [&](const LightView& v, Vec3f p) {
    const Vec3f t = v.to_texel(p);
    return t.x >= 0 && t.x < static_cast<float>(v.width()) && t.y >= 0 && t.y < static_cast<float>(v.height());
  };
  const LightView capped = fit_shadow_view(eye, {0, -1, 0}, {0, 0, 1}, receivers, {}, fit);
  EXPECT_TRUE(covered(capped, {6.5f, 0, 0}));
  EXPECT_FALSE(covered(capped, {8, 0, 0}));
  // The view's x axis: right = forward x up = (0, -1, 0) x (0, 0, 1) = (-1, 0, 0), so +x in the
  // world is -x/z in the view.
  fit.reach_x0 = -6;
  fit.reach_x1 = -5;
  fit.reach_y0 = -1;
  fit.reach_y1 = 1;
  const LightView reached = fit_shadow_view(eye, {0, -1, 0}, {0, 0, 1}, receivers, {}, fit);
  EXPECT_TRUE(covered(reached, {2, 0, 0}));
  EXPECT_TRUE(covered(reached, {23.9f, 0, 0}));
  EXPECT_FALSE(covered(reached, {24.5f, 0, 0}));
  // A reach inside the cap changes nothing.
  fit.reach_x0 = -1;
  fit.reach_x1 = -0.5f;
  const LightView inside = fit_shadow_view(eye, {0, -1, 0}, {0, 0, 1}, receivers, {}, fit);
  EXPECT_EQ(inside.window_left(), capped.window_left());
  EXPECT_EQ(inside.window_right(), capped.window_right());
}

TEST(ShadowView, RejectsReceiversBehindTheEyeAndBadSettings) {
  std::vector<Vec3f> behind = {{0, 2, 0}, {1, 3, 0}};
  EXPECT_NE(test::error_message([&] { fit_shadow_view({0, 1, 0}, {0, -1, 0}, {0, 0, 1}, behind, {}, {}); })
                .find("in front"),
            std::string::npos);
  std::vector<Vec3f> ok = {{0, 0, 0}};
  ShadowViewFit bad;
  bad.resolution = 0;
  EXPECT_THROW(fit_shadow_view({0, 1, 0}, {0, -1, 0}, {0, 0, 1}, ok, {}, bad), Error);
  bad.resolution = 16;
  bad.max_fov = 180;
  EXPECT_THROW(fit_shadow_view({0, 1, 0}, {0, -1, 0}, {0, 0, 1}, ok, {}, bad), Error);
  // A single receiver still gives a valid (tiny) window.
  LightView v = fit_shadow_view({0, 1, 0}, {0, -1, 0}, {0, 0, 1}, ok, {}, {});
  Vec3f t = v.to_texel({0, 0, 0});
  EXPECT_GE(t.x, 0.0f);
  EXPECT_LT(t.x, static_cast<float>(v.width()));
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
