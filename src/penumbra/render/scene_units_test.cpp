// Two properties every method's V must have whatever the scene, on the CPU (the GPU's are in
// gpu_renderer_test.cpp):
// - A scene means the same in any unit. The same scene modelled 100 times smaller (a desk-top
//   scene in metres) or 10^5 times larger (a street in millimetres, 10^5 units from its light)
//   gives the same V as at its own size. World-unit tolerances are where this breaks: a depth
//   bias of 0.001 is a third of a texel at a unit's size, 30 texels at 1/100 of it (light through
//   every contact), and below the float resolution of depths of 10^5 (acne everywhere).
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

TEST_P(SceneUnits, VIsZeroWhereTheLightFacesAway) {
  const std::string& method = GetParam();
  const RenderResult r = render_scene(testing::facing_away_ground_only(), settings_for(method));
  for (float v : r.visibility.data()) ASSERT_EQ(v, 0.0f) << method;
  for (float c : r.color.data()) ASSERT_EQ(c, 0.0f) << method;
}

INSTANTIATE_TEST_SUITE_P(Methods, SceneUnits, ::testing::ValuesIn(testing::registered_method_names()),
                         testing::method_test_name);

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
