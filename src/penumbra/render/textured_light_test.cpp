// Issue 20 part 3: a textured area light (a rect whose emission is an image). A two-colour
// light (left half red, right half blue) behind the straight edge of a thin occluder halfway
// down gives a closed-form coloured penumbra, for every method that takes points on the light;
// the methods that model it as uniform (MethodInfo::uniform_light) see its mean colour (the
// same V in every channel).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "penumbra/render/renderer.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

constexpr float kH = 4.0f;      // the light's height; the occluder's edge is at kH / 2
constexpr float kWidth = 1.0f;  // the light is kWidth x kWidth, red for x < 0, blue for x > 0

Scene two_colour_scene() {
  AreaLight light = testing::rect_light_down({0, kH, 0}, kWidth, kWidth);  // u = frame.s = +x
  auto image = std::make_shared<const Texture>(2, 1, std::vector<float>{1, 0, 0, 1, 0, 0, 1, 1}, false, "red|blue");
  light.texture = std::make_shared<const LightTexture>(image);
  std::vector<SceneObject> occluders;
  // A thin occluder over x < 0 at half the light's height, wide along z.
  occluders.push_back(testing::object(testing::quad_y(kH / 2, -6, 0, -6, 6)));
  Scene s = testing::ground_scene(std::move(occluders), light, 48);
  // Looking at the ground from below the occluder, across the penumbra.
  s.camera.eye = {0, 0.8f, 2.5f};
  s.camera.target = {0, 0, 0};
  s.camera.up = {0, 1, 0};
  s.camera.fov_y = 40;
  return s;
}

// The fraction of each half of the light a ground point at x sees: light points at x' (along x)
// are visible iff the segment passes the edge, x + (x' - x) / 2 >= 0, i.e. x' >= -x.
float closed_form_red(float x) { return std::clamp(2 * x / kWidth, 0.0f, 1.0f); }
float closed_form_blue(float x) { return 1 - std::clamp(-2 * x / kWidth, 0.0f, 1.0f); }

struct ChannelCheck {
  double max_error[2] = {0, 0};  // red, blue
  int pixels = 0, penumbra = 0;
  double max_channel_difference = 0;  // |V_red - V_blue|
};

// Per pixel on the ground near the penumbra: V of each channel from the colour, V_c = colour_c
// pi / (albedo radiance_c mean_c U) with U the light's unshadowed irradiance per unit radiance.
ChannelCheck check(const Scene& scene, const std::string& method) {
  RenderSettings settings;
  settings.method = method;
  settings.light_samples = 256;
  settings.seed = 3;
  const RenderResult r = render_scene(scene, settings);
  const AreaLight& light = scene.lights[0];
  const Camera& cam = scene.camera;
  ChannelCheck c;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const Vec3f d = cam.ray_direction(x + 0.5f, y + 0.5f);
      if (!(d.y < 0)) continue;
      const Vec3f p = cam.eye + d * (-cam.eye.y / d.y);
      if (std::abs(p.x) > 0.8f || std::abs(p.z) > 1.0f) continue;
      const float u = light.unshadowed_irradiance_scalar(p, {0, 1, 0});
      const float scale = 0.8f / kPi * u * 0.5f;  // albedo / pi * U * the channel's mean (half the texels)
      const size_t i = static_cast<size_t>(y) * cam.width + x;
      const float v[2] = {r.color.pixel(i)[0] / scale, r.color.pixel(i)[2] / scale};
      const float expected[2] = {closed_form_red(p.x), closed_form_blue(p.x)};
      for (int k = 0; k < 2; ++k) c.max_error[k] = std::max(c.max_error[k], static_cast<double>(std::abs(v[k] - expected[k])));
      c.max_channel_difference = std::max(c.max_channel_difference, static_cast<double>(std::abs(v[0] - v[1])));
      ++c.pixels;
      c.penumbra += std::abs(p.x) < 0.45f;
    }
  return c;
}

TEST(TexturedLight, TwoColourLightGivesTheClosedFormColouredPenumbra) {
  const Scene scene = two_colour_scene();
  ASSERT_EQ(expand_textured_lights(scene.lights).size(), 2u);  // red and blue; no green
  for (const MethodInfo* info : MethodRegistry::all()) {
    SCOPED_TRACE(info->name);
    const ChannelCheck c = check(scene, info->name);
    ASSERT_GT(c.penumbra, 50);
    std::printf("%-20s max |V - closed form| red %.3f blue %.3f, max |V_red - V_blue| %.3f\n", info->name.c_str(),
                c.max_error[0], c.max_error[1], c.max_channel_difference);
    if (!info->uniform_light) {
      // Sampling noise of 256 stratified samples a channel (the reference's E also weights the
      // light by cos^2 / r^2: a few % over it); pcss's PCF kernel of light points is an
      // approximation, rt-denoised has 4 samples and a filter.
      const double tolerance = info->name == "pcss" ? 0.1 : info->name == "rt-denoised" ? 0.2 : 0.05;
      EXPECT_LE(c.max_error[0], tolerance) << "red";
      EXPECT_LE(c.max_error[1], tolerance) << "blue";
      EXPECT_GT(c.max_channel_difference, 0.8);  // coloured: red and blue differ across the penumbra
    } else {
      // The light's mean colour: the same V in both channels.
      EXPECT_LE(c.max_channel_difference, 1e-4);
    }
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
