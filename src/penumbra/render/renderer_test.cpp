// The Renderer's frame-to-frame reuse, which the viewer builds on: new lights over the same
// geometry, and one progressive frame at a time.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "penumbra/render/renderer.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/testing/image_bits.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

Scene two_light_scene() {
  std::vector<SceneObject> occluders;
  occluders.push_back(testing::object(testing::box({-0.5f, 0.3f, -0.4f}, {0.2f, 0.8f, 0.3f})));
  Scene s = testing::ground_scene(std::move(occluders), testing::rect_light_down({0, 2, 0}, 1.0f, 0.8f), 32);
  s.lights.push_back(testing::rect_light_down({0.8f, 2.5f, 0.3f}, 0.6f, 0.6f, Vec3f(0.5f)));
  return s;
}

using testing::same_bits;

// For each method: render, move one light, render again with the same Renderer; the second
// image equals a fresh Renderer's of the moved scene bit for bit, and the unmoved light's
// light-space structures were kept (its method instance is the same object).
TEST(Renderer, SetLightsEqualsAFreshRendererAndKeepsUnchangedLights) {
  for (const char* method : {"hard", "shadow-map", "lam", "occlusion-textures", "reference", "multi-view-sm"}) {
    SCOPED_TRACE(method);
    Scene scene = two_light_scene();
    RenderSettings settings;
    settings.method = method;
    settings.light_samples = 16;
    Renderer r(scene, settings);
    r.render();
    ShadowMethod* kept = &r.method(1);
    Scene moved = scene;
    moved.lights[0].center = moved.lights[0].center + Vec3f(0.4f, 0.1f, -0.2f);
    r.set_lights(moved.lights);
    EXPECT_FALSE(r.prepared());
    EXPECT_EQ(&r.method(1), kept);
    RenderResult reused = r.render();
    EXPECT_TRUE(r.prepared());
    RenderResult fresh = render_scene(moved, settings);
    EXPECT_TRUE(same_bits(reused.color, fresh.color));
    EXPECT_TRUE(same_bits(reused.visibility, fresh.visibility));
    // Fewer lights, then the same ones again.
    Scene one = moved;
    one.lights.resize(1);
    r.set_lights(one.lights);
    EXPECT_TRUE(same_bits(r.render().visibility, render_scene(one, settings).visibility));
  }
}

// Issue 18 part 3, for every registered method: a sequence rendered by one Renderer that keeps
// what stays valid (the Embree scene and every light's light-space structures while only the
// camera moves, the unchanged light's when one light moves) equals the same frames rendered
// from scratch, bit for bit (every method is deterministic: determinism_test.cpp). A method
// that kept something depending on the view (a light view fitted to the last frame's pixels)
// would differ from the second frame on.
TEST(Renderer, EveryMethodsReusedFramesEqualFreshRendersAlongACameraWalkAndALightMove) {
  const Scene base = two_light_scene();
  std::vector<Scene> frames;
  for (int f = 0; f < 3; ++f) {  // the camera walks around and toward the box
    Scene s = base;
    const float a = 0.5f * static_cast<float>(f);
    s.camera.eye = {2.5f * std::sin(a), 3.0f - 0.4f * static_cast<float>(f), 2.5f * std::cos(a)};
    s.camera.up = {0, 1, 0};
    frames.push_back(s);
  }
  Scene moved = frames.back();  // then the first light moves
  moved.lights[0].center = moved.lights[0].center + Vec3f(-0.3f, 0.2f, 0.25f);
  frames.push_back(moved);

  for (const MethodInfo* info : MethodRegistry::all()) {
    SCOPED_TRACE(info->name);
    RenderSettings settings;
    settings.method = info->name;
    settings.light_samples = 8;
    settings.seed = 3;
    Renderer r(frames[0], settings);
    for (size_t f = 0; f < frames.size(); ++f) {
      SCOPED_TRACE(f);
      r.set_camera(frames[f].camera);
      r.set_lights(frames[f].lights);
      const RenderResult reused = r.render();
      const RenderResult fresh = render_scene(frames[f], settings);
      EXPECT_TRUE(same_bits(reused.visibility, fresh.visibility));
      EXPECT_TRUE(same_bits(reused.color, fresh.color));
      // Only the moved light's method prepared again.
      EXPECT_EQ(reused.stats.prepare_count, f == 0 ? 2u : f == 3 ? 1u : 0u);
    }
  }
}

// Objects moving (Renderer::set_objects, the Embree scene refit): for every method, the frames
// of a Renderer whose box turns and slides equal fresh renders of the moved scene, up to the
// pixels where Embree reports one of two equally near triangles (an edge both contain) in
// another order than a fresh build does; methods that prepare nothing from the geometry keep
// their instances, every other prepares again.
TEST(Renderer, EveryMethodsFramesAfterObjectsMoveEqualFreshRenders) {
  const Scene base = two_light_scene();
  std::vector<Scene> frames = {base};
  for (int k = 1; k <= 2; ++k) {
    Scene s = base;
    ObjectTransform t;
    t.translate = {0.2f * k, 0.05f * k, -0.15f * k};
    t.rotate = {0, 20.0f * k, 0};
    place_object(s.objects[1], t);
    frames.push_back(s);
  }
  const std::vector<uint32_t> box = {1};
  for (const MethodInfo* info : MethodRegistry::all()) {
    SCOPED_TRACE(info->name);
    RenderSettings settings;
    settings.method = info->name;
    settings.light_samples = 8;
    settings.seed = 3;
    RenderSettings movable = settings;
    movable.movable_objects = box;
    Renderer r(frames[0], movable);
    // What the method says it keeps; reference and hard prepare nothing from the geometry.
    const bool keeps = create_method(info->name, base, {})->keeps_prepared_after_moving(box, ShadowContext{});
    if (info->name == "reference" || info->name == "hard") EXPECT_TRUE(keeps);
    for (size_t f = 0; f < frames.size(); ++f) {
      SCOPED_TRACE(f);
      if (f > 0) r.set_objects(frames[f].objects, box);
      const RenderResult reused = r.render();
      const RenderResult fresh = render_scene(frames[f], settings);
      EXPECT_EQ(reused.stats.prepare_count, f == 0 || !keeps ? 2u : 0u);
      size_t same = 0;
      double diff = 0;
      const std::vector<float>&a = reused.visibility.data(), &b = fresh.visibility.data();
      for (size_t i = 0; i < a.size(); ++i) {
        same += a[i] == b[i];
        diff += std::abs(a[i] - b[i]);
      }
      EXPECT_GE(static_cast<double>(same), 0.995 * static_cast<double>(a.size()));
      EXPECT_LE(diff / static_cast<double>(a.size()), 1e-3);
    }
    EXPECT_EQ(r.tracer().refits(), 2);
  }
}

// A sphere light is split by the scene's bounds (split_sphere_lights); when objects move, the
// split follows the new bounds, so the frame equals a fresh render of the moved scene. The room's
// ceiling, walls and shelf start low (nothing reaches behind the bulb's disk: one light) and move
// up around the bulb (the cube's faces). Before, set_objects kept the old split: the ceiling and the
// walls' upper half stayed dark.
TEST(Renderer, MovingObjectsSplitsASphereLightByTheNewBounds) {
  const Scene room = testing::bulb_in_a_room_scene(24);
  const Scene below = testing::bulb_room_lowered_scene(24);
  const std::vector<uint32_t> moved = {1, 2, 3, 4, 5, 6};
  for (const char* method : {"shadow-map", "afsm"}) {
    SCOPED_TRACE(method);
    RenderSettings settings;
    settings.method = method;
    settings.light_samples = 16;
    RenderSettings movable = settings;
    movable.movable_objects = moved;
    Renderer r(below, movable);
    EXPECT_EQ(r.scene().lights.size(), 1u);
    r.render();
    r.set_objects(room.objects, moved);
    EXPECT_GT(r.scene().lights.size(), 1u);
    const RenderResult reused = r.render();
    const RenderResult fresh = render_scene(room, settings);
    const std::vector<float>&a = reused.visibility.data(), &b = fresh.visibility.data();
    double diff = 0;
    for (size_t i = 0; i < a.size(); ++i) diff += std::abs(a[i] - b[i]);
    EXPECT_LE(diff / static_cast<double>(a.size()), 1e-4);
    // And back: under the floor again, one light.
    r.set_objects(below.objects, moved);
    EXPECT_EQ(r.scene().lights.size(), 1u);
  }
}

// The mean of frames 0..K-1 rendered one at a time (first_frame = k) is the render with
// frames = K, up to float rounding: the viewer's progressive refinement shows `--frames K`.
TEST(Renderer, FramesRenderedOneAtATimeAverageToTheFramesRender) {
  Scene scene = two_light_scene();
  RenderSettings settings;
  settings.method = "reference";
  settings.light_samples = 4;
  const int K = 5;
  Renderer r(scene, settings);
  Image sum_v(scene.camera.width, scene.camera.height, 1, 0.0f);
  Image sum_c(scene.camera.width, scene.camera.height, 3, 0.0f);
  bool frames_differ = false;
  Image first;
  for (int k = 0; k < K; ++k) {
    r.set_first_frame(k);
    RenderResult f = r.render();
    if (k == 0) first = f.visibility;
    else frames_differ = frames_differ || !same_bits(first, f.visibility);
    for (size_t i = 0; i < sum_v.data().size(); ++i) sum_v.data()[i] += f.visibility.data()[i];
    for (size_t i = 0; i < sum_c.data().size(); ++i) sum_c.data()[i] += f.color.data()[i];
  }
  EXPECT_TRUE(frames_differ) << "each frame must draw new light samples";
  settings.frames = K;
  RenderResult all = render_scene(scene, settings);
  double max_dv = 0, max_dc = 0;
  for (size_t i = 0; i < sum_v.data().size(); ++i)
    max_dv = std::max(max_dv, std::abs(double(sum_v.data()[i]) / K - all.visibility.data()[i]));
  for (size_t i = 0; i < sum_c.data().size(); ++i)
    max_dc = std::max(max_dc, std::abs(double(sum_c.data()[i]) / K - all.color.data()[i]));
  EXPECT_LT(max_dv, 1e-5);
  EXPECT_LT(max_dc, 1e-4);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
