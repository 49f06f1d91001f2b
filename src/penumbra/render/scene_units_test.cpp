// Three properties every method's V must have whatever the scene, on the CPU (the GPU's are in
// gpu_renderer_test.cpp):
// - A scene means the same in any unit. The same scene modelled 100 times smaller (a desk-top
//   scene in metres) or 10^5 times larger (a street in millimetres, 10^5 units from its light)
//   gives the same V as at its own size. World-unit tolerances are where this breaks: a depth
//   bias of 0.001 is a third of a texel at a unit's size, 30 texels at 1/100 of it (light through
//   every contact), and below the float resolution of depths of 10^5 (acne everywhere).
// - A scene far from the world's origin (a georeferenced model) is drawn as well as at the
//   origin: the ground truth stays where it is, and no method's error against it grows. A ray
//   offset or a projection sized by world coordinates is where this breaks.
// - What lies on or behind a light's plane changes no V: a ceiling flush with a panel light, or
//   just above it, blocks none of its light. A method that maps its casters from the light's side
//   or projects them onto it is where this breaks (the ceiling covered every light sample).
// - A sphere light inside the scene (a bulb in a room) lights what lies behind the one disk facing
//   the scene that the light-space methods sample: the ceiling and the walls' upper half.
// - V = 0 where the light's emitting side does not face the point (behind a rect light's plane):
//   the point sees none of the light, whatever the method's rays or maps would say there.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "penumbra/render/renderer.h"
#include "penumbra/testing/every_method.h"
#include "penumbra/testing/gpu_method_runs.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

class SceneUnits : public ::testing::TestWithParam<std::string> {};

RenderSettings settings_for(const std::string& method) { return testing::device_settings(method, {}, false, 3, 16); }

TEST_P(SceneUnits, TheSameSceneAHundredTimesSmallerOrAHundredThousandTimesLargerHasTheSameV) {
  const std::string& method = GetParam();
  const RenderResult unit = render_scene(testing::contact_scene_at_scale(1.0f), settings_for(method));
  for (float scale : {1e-2f, 1e5f}) {
    const RenderResult scaled = render_scene(testing::contact_scene_at_scale(scale), settings_for(method));
    const double dv = testing::mean_abs_dv(scaled.visibility, unit.visibility);
    std::printf("%-20s scale %g: mean |dV| against scale 1: %.5f\n", method.c_str(), scale, dv);
    EXPECT_LE(dv, testing::kSceneUnitsTolerance) << method << " at scale " << scale;
  }
}

// The offsets: 10^3, and 2 x 10^4 (a georeferenced model: float coordinates there are exact to
// 0.002, though every distance in the scene is unit-sized).
const Vec3f kOffsets[] = {Vec3f(1e3f, 0, -1e3f), Vec3f(2e4f, 50.0f, -1.5e4f)};

// The ground truth (`reference`, 256 samples) of contact_scene_at_scale(1) at the origin (index 0)
// and at each offset, rendered once for every method's test.
const Image& ground_truth(int offset_index) {
  static const std::vector<Image> truths = [] {
    std::vector<Image> out;
    for (int i = 0; i <= 2; ++i) {
      const Vec3f offset = i == 0 ? Vec3f(0.0f) : kOffsets[i - 1];
      out.push_back(render_scene(testing::contact_scene_at_scale(1.0f, 40, offset), testing::device_settings("reference", {}, false, 3, 256)).visibility);
    }
    return out;
  }();
  return truths[offset_index];
}

TEST(SceneOffsets, TheGroundTruthFarFromTheOriginIsTheSame) {
  // Before the ray offset followed the coordinates' ulps (trace/ray_shared.h) every ray left its
  // surface 0.6 units out at 2 x 10^4 and the plate's contact shadow was gone: 0.049.
  for (int i = 1; i <= 2; ++i) {
    const double dv = testing::mean_abs_dv(ground_truth(i), ground_truth(0));
    std::printf("reference offset %g: mean |dV| against the origin: %.5f\n", kOffsets[i - 1].x, dv);
    EXPECT_LE(dv, testing::kSceneUnitsTolerance) << "offset " << kOffsets[i - 1].x;
  }
}

TEST_P(SceneUnits, FarFromTheOriginEveryMethodIsAsCloseToTheGroundTruth) {
  // Not the same picture: a method's own artifacts (acne where its light grazes a face, the
  // phase of its texels against an edge) move when the input's rounding moves a corner by 0.001;
  // its error against the ground truth must not grow.
  const std::string& method = GetParam();
  const double here = testing::mean_abs_dv(render_scene(testing::contact_scene_at_scale(1.0f), settings_for(method)).visibility, ground_truth(0));
  for (int i = 1; i <= 2; ++i) {
    const RenderResult far = render_scene(testing::contact_scene_at_scale(1.0f, 40, kOffsets[i - 1]), settings_for(method));
    const double there = testing::mean_abs_dv(far.visibility, ground_truth(i));
    std::printf("%-20s offset %g: mean |dV| %.5f, at the origin %.5f\n", method.c_str(), kOffsets[i - 1].x, there, here);
    EXPECT_LE(there, 1.25 * here + 0.001) << method << " at offset " << kOffsets[i - 1].x;
  }
}

TEST_P(SceneUnits, VIsZeroWhereTheLightFacesAway) {
  const std::string& method = GetParam();
  const RenderResult r = render_scene(testing::facing_away_ground_only(), settings_for(method));
  for (float v : r.visibility.data()) ASSERT_EQ(v, 0.0f) << method;
  for (float c : r.color.data()) ASSERT_EQ(c, 0.0f) << method;
}

// The ceiling reaches 0.4 and 0.6 past the light's edges and stays out of the camera's view (the
// camera is above the light's plane).
constexpr float kCeilingHalfSize = 1.0f;

TEST_P(SceneUnits, ACeilingFlushWithTheLightOrBehindItChangesNoV) {
  // Before (flush / 0.001 behind): afsm 0.37 / 0 (the ceiling's corners round to a hair in front
  // of the plane), mlsm and mtsm 0.43 / 0.41 (the map started 0.1% before the light's plane),
  // single-sample 0.69 / 0.69 (its outer objects, b(t) wide at the light, covered it).
  const std::string& method = GetParam();
  const Scene scene = testing::contact_scene_at_scale(1.0f, 32);
  const RenderResult bare = render_scene(scene, settings_for(method));
  for (float gap : {0.0f, 1e-3f}) {
    const RenderResult ceiling = render_scene(testing::with_a_ceiling_at_the_light(scene, gap, kCeilingHalfSize), settings_for(method));
    const double dv = testing::mean_abs_dv(ceiling.visibility, bare.visibility);
    std::printf("%-20s ceiling %g behind the light: mean |dV| against none %.5f\n", method.c_str(), gap, dv);
    EXPECT_LE(dv, testing::kSceneUnitsTolerance) << method << " with the ceiling " << gap << " behind the light";
  }
}

TEST_P(SceneUnits, ABulbInARoomLightsTheCeilingAndTheWallsBehindItsDisk) {
  // Before the renderer split such a sphere into the faces of a cube (split_sphere_lights), the
  // methods that sample one disk drew the upper half of the room black: 0.51-0.53 at 64 x 64
  // (docs/data/scenes/bulb-room.json), against hard's 0.0125.
  const std::string& method = GetParam();
  static const Image truth =
      render_scene(testing::bulb_in_a_room_scene(32), testing::device_settings("reference", {}, false, 3, 256))
          .visibility;
  const RenderResult r = render_scene(testing::bulb_in_a_room_scene(32), settings_for(method));
  const double dv = testing::mean_abs_dv(r.visibility, truth);
  std::printf("%-20s a bulb in a room: mean |dV| %.5f\n", method.c_str(), dv);
  EXPECT_LE(dv, 0.05) << method;
}

INSTANTIATE_TEST_SUITE_P(Methods, SceneUnits, ::testing::ValuesIn(testing::registered_method_names()),
                         testing::method_test_name);

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
