// `ssv-rt` on the GPU (issue 30, held to afsm's exactness standard): every view sample against
// GPU rays traced to ssv-rt's own N fixed light points, the CPU version's picture (bunny,
// foliage's alpha masks), semi-transparent casters, a crop, progressive frames, the one-line
// refusals and the memory estimate. Small renders: lavapipe is slow.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/shadow/light_samples.h"
#include "penumbra/shadow/soft_shadow_volumes/soft_shadow_volumes_gpu_testing.h"
#include "penumbra/testing/gpu_method_runs.h"
#include "penumbra/testing/method_runs.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::box;
using testing::ground_scene;
using testing::object;
using testing::quad_y;
using testing::rect_light_down;

class SoftShadowVolumesGpu : public testing::GpuMethodTest {
 protected:
  SoftShadowVolumesGpu() : GpuMethodTest("ssv-rt", 16, {}) {}

  // `r`'s scene on the GPU at n light samples: every view sample's V against GPU rays to the
  // same n points (the renderer's seed, light 0, frame 0); then the CPU version's picture.
  RenderResult expect_exact(const testing::SceneRun& r, const std::string& name, int n) {
    RenderSettings settings = testing::device_settings("ssv-rt", {}, true);
    settings.light_samples = n;
    const RenderResult gpu = render_scene(r.scene, settings);
    EXPECT_EQ(gpu.device, device().info().name);
    const std::vector<float> v = testing::per_sample(r, gpu);
    const LightSamples pts = make_light_samples(r.scene.lights[0], n, settings.seed, 0, 0);
    const std::vector<float> rays = testing::gpu_rays_to_points(device(), r, pts.points);
    const testing::Agreement g = testing::agreement(v, rays);
    std::printf("GPU ssv-rt N=%d vs GPU rays to the same points, %s: %.5f of %zu equal, max |dV| %.5f\n", n,
                name.c_str(), g.equal_fraction, v.size(), g.max_diff);
    EXPECT_GE(g.equal_fraction, 0.999) << name << ", " << testing::worst_sample(r, v, rays);
    EXPECT_LE(g.max_diff, 1.0f / n + 1e-6f) << name << ", " << testing::worst_sample(r, v, rays);
    EXPECT_GT(std::count_if(v.begin(), v.end(), [](float x) { return x > 0.05f && x < 0.95f; }), 10) << "no penumbra";
    EXPECT_GT(gpu.stats.extra["edge_updates"].get<uint64_t>(), 0u);
    EXPECT_GT(gpu.stats.extra["sample_groups"].get<uint64_t>(), 0u);
    RenderSettings cpu_settings = settings;
    cpu_settings.device = {};
    const RenderResult cpu = render_scene(r.scene, cpu_settings);
    const double dv = testing::mean_abs_dv(cpu.visibility, gpu.visibility);
    std::printf("GPU ssv-rt N=%d vs CPU, %s: mean |dV| %.2e\n", n, name.c_str(), dv);
    RecordProperty("mean_abs_dv_" + name, testing::dv_text(dv));
    EXPECT_LE(dv, 2e-3) << name;
    return gpu;
  }
};

TEST_F(SoftShadowVolumesGpu, BunnyEqualsGpuRaysToTheSameLightPointsAndTheCpu) {
  expect_exact(testing::load_scene_at("bunny", 32), "bunny", 32);
}

// Alpha-masked leaves: no silhouette edges; their samples' transmittance through the masks.
TEST_F(SoftShadowVolumesGpu, AlphaMaskedFoliageEqualsGpuRaysToTheSameLightPointsAndTheCpu) {
  expect_exact(testing::load_scene_at("foliage", 32), "foliage", 32);
}

// The light samples split over dispatches (lavapipe's loop limit splits them so where a thread's
// loops run too long, gpu::LoopLimitSplit), here forced to 24 a dispatch: each dispatch adds its
// share, the picture is exact as before and the CPU's.
TEST_F(SoftShadowVolumesGpu, LightSamplesSplitOverDispatchesGiveTheSamePicture) {
  const testing::SceneRun r = testing::load_scene_at("foliage", 24);
  RenderSettings settings = testing::device_settings("ssv-rt", {}, true);
  settings.light_samples = 100;
  const RenderResult whole = render_scene(r.scene, settings);
  ssv::SsvSamplesPerDispatchForTesting split(24);
  const RenderResult gpu = expect_exact(r, "foliage-split", 100);
  EXPECT_EQ(gpu.stats.extra["dispatches_per_frame"].get<int>(), 5);
  EXPECT_LE(testing::mean_abs_dv(whole.visibility, gpu.visibility), 1e-6);
  // The walk's counts once per frame, not per dispatch.
  EXPECT_EQ(whole.stats.extra["edge_tests"], gpu.stats.extra["edge_tests"]);
}

// An open quad (boundary edges), a closed box, and two overlapping semi-transparent quads
// (opacity 0.5, 0.3): V takes the fractional values of the transmittance, as on the CPU.
TEST_F(SoftShadowVolumesGpu, SemiTransparentCastersGiveTheirTransmittance) {
  const AreaLight light = rect_light_down({0.3f, 2.2f, 0.1f}, 1.0f, 0.6f);
  const testing::SceneRun r = testing::build_scene_run(
      ground_scene({object(quad_y(0.9f, -1.0f, 0.2f, -0.6f, 0.4f)), object(box({0.4f, 0, -0.5f}, {0.9f, 0.6f, 0.2f})),
                    object(quad_y(1.2f, 0.2f, 1.0f, -0.7f, 0.0f), Vec3f(0.8f), 0.5f),
                    object(quad_y(1.4f, 0.5f, 1.3f, -0.3f, 0.3f), Vec3f(0.8f), 0.3f)},
                   light, 32));
  const RenderResult gpu = expect_exact(r, "semi-transparent", 20);
  const std::vector<float> v = testing::per_sample(r, gpu);
  EXPECT_GT(std::count_if(v.begin(), v.end(), [](float x) { return std::abs(x * 20 - std::round(x * 20)) > 1e-3f; }),
            20);
}

// ssv-rt is tile-exact: a crop's pixels are the whole frame's, and the CPU's crop.
TEST_F(SoftShadowVolumesGpu, CropEqualsTheWholeFrameAndTheCpu) {
  const Scene scene = testing::shipped_scene("bunny.json", 32);
  EXPECT_LE(crop_difference(scene, PixelWindow{4, 10, 28, 30}, /*tile_exact=*/true), 2e-3);
}

// A second frame (progressive, --frames) draws other light samples, as the CPU does.
TEST_F(SoftShadowVolumesGpu, ProgressiveFramesGiveTheCpuPicture) {
  const Scene scene = testing::shipped_scene("bunny.json", 32);
  RenderSettings s = settings(true);
  s.frames = 2;
  EXPECT_LE(difference(scene, s, "frames"), 2e-3);
}

// More light samples than a work group holds, and scenes without casters: one-line refusals or
// plain light, never a crash.
TEST_F(SoftShadowVolumesGpu, TooManyLightSamplesIsAOneLineError) {
  const Scene scene = testing::shipped_scene("bunny.json", 16);
  RenderSettings s = settings(true);
  s.light_samples = 4096;
  try {
    render_scene(scene, s);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("--spp 4096"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

// The up-front estimate covers what a render holds on the device.
TEST_F(SoftShadowVolumesGpu, MemoryEstimateCoversTheRender) {
  const Scene scene = testing::shipped_scene("foliage.json", 24);
  RenderSettings s = settings(true);
  const RenderResult gpu = render_scene(scene, s);
  const MemoryEstimate e = testing::gpu_memory_estimate("ssv-rt", scene, {}, gpu.view_sample_count);
  EXPECT_GT(gpu.stats.memory_bytes, 0u);
  EXPECT_GE(e.bytes, gpu.stats.memory_bytes);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
