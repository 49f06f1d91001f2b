// Every registered method, not only `reference`, gives the same image bit for bit with one
// and with two worker threads at the same seed (issue 17): work is split by index and
// randomness keyed by index (core/parallel.h, core/rng.h), and this holds them to it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>

#include "penumbra/core/parallel.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// A box and a semi-transparent quad over the ground under a rect light: umbra, penumbra,
// transmittance and a closed mesh, at a size every method renders in well under a second.
Scene determinism_scene() {
  std::vector<SceneObject> occluders;
  occluders.push_back(testing::object(testing::box({-0.6f, 0.3f, -0.4f}, {0.1f, 0.8f, 0.3f})));
  occluders.push_back(testing::object(testing::quad_y(1.1f, 0.2f, 1.0f, -0.6f, 0.5f), Vec3f(0.6f), 0.4f));
  return testing::ground_scene(std::move(occluders), testing::rect_light_down({0, 2, 0}, 1.2f, 0.8f), 40);
}

// The index of the first float where a and b differ, or -1.
long first_difference(const Image& a, const Image& b) {
  if (a.width() != b.width() || a.height() != b.height() || a.channels() != b.channels()) return 0;
  const size_t n = a.pixel_count() * a.channels();
  for (size_t i = 0; i < n; ++i)
    if (std::memcmp(&a.data()[i], &b.data()[i], sizeof(float)) != 0) return static_cast<long>(i);
  return -1;
}

TEST(Determinism, EveryMethodGivesTheSameImageWithOneAndTwoThreads) {
  const Scene scene = determinism_scene();
  const auto methods = MethodRegistry::all();
  ASSERT_GE(methods.size(), 13u);
  for (const MethodInfo* info : methods) {
    SCOPED_TRACE(info->name);
    RenderSettings settings;
    settings.method = info->name;
    settings.light_samples = 16;
    settings.seed = 7;
    RenderResult one, two;
    {
      ThreadLimit limit(1);
      one = render_scene(scene, settings);
    }
    {
      ThreadLimit limit(2);
      two = render_scene(scene, settings);
    }
    EXPECT_EQ(first_difference(one.visibility, two.visibility), -1) << "V differs";
    EXPECT_EQ(first_difference(one.color, two.color), -1) << "colour differs";
    // Not the trivial image: the occluders cast a shadow in every method.
    float v_min = 1.0f;
    for (size_t i = 0; i < one.visibility.pixel_count(); ++i) v_min = std::min(v_min, one.visibility.pixel(i)[0]);
    EXPECT_LT(v_min, 0.5f);
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
