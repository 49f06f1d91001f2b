// The horizon term of closed receivers (light_horizon.h), which vsm, evsm, msm and
// occlusion-textures multiply their V by.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "penumbra/shadow/light_horizon.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::rect_light_down;

// The horizon term of closed receivers: the fraction of the light's rectangle above p's
// tangent plane, by polygon clipping.
TEST(LightHorizon, FractionOfTheLightAboveTheTangentPlane) {
  const AreaLight light = rect_light_down({0, 2, 0}, 1.0f, 0.5f);
  EXPECT_FLOAT_EQ(light_fraction_above(light, {0, 0, 0}, {0, 1, 0}), 1.0f);
  EXPECT_FLOAT_EQ(light_fraction_above(light, {0, 0, 0}, {0, -1, 0}), 0.0f);
  // A vertical plane through the light's centre line: half of it.
  EXPECT_NEAR(light_fraction_above(light, {0, 0, 0}, {1, 0, 0}), 0.5f, 1e-6);
  // A plane through p = (0.25, 2, 0)'s vertical line: the light's x in (0.25, 0.5], a quarter.
  EXPECT_NEAR(light_fraction_above(light, {0.25f, 0, 0}, {1, 0, 0}), 0.25f, 1e-6);
  // Tilted: the plane through the origin with normal (1, 1, 0)/sqrt2 meets the light's plane
  // (y = 2) at x = -2: all of the light is above.
  EXPECT_FLOAT_EQ(light_fraction_above(light, {0, 0, 0}, normalize(Vec3f(1, 1, 0))), 1.0f);
}

// A disk is the square of equal area along its axes (side r sqrt(pi)): a plane through its centre
// leaves half, one through the square's edge none.
TEST(LightHorizon, ADiskIsTheSquareOfEqualArea) {
  AreaLight disk = rect_light_down({0, 2, 0}, 1.0f, 1.0f);
  disk.shape = LightShape::Disk;
  disk.radius = 0.5f;
  const Vec2f h = light_half_axes(disk);
  EXPECT_NEAR(h.x, 0.25f * std::sqrt(std::numbers::pi_v<float>), 1e-6);
  EXPECT_EQ(h.x, h.y);
  EXPECT_NEAR(light_fraction_above(disk, {0, 0, 0}, {1, 0, 0}), 0.5f, 1e-6);
  EXPECT_FLOAT_EQ(light_fraction_above(disk, {h.x + 1e-3f, 0, 0}, {1, 0, 0}), 0.0f);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
