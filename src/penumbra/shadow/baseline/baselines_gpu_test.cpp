// `shadow-map` and `pcss` on the GPU against their CPU versions: the same pictures (mean |dV| at
// most 1e-3, issue 28), every parameter, the stages and statistics, the re-render rule and the
// memory estimate. Small renders: lavapipe is slow.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "penumbra/eval/run_setup.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/testing/gpu_method_runs.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using gpu::testing::GpuTest;

// The shipped scenes, render settings on either device and mean |dV| (testing/gpu_method_runs.h).
Scene shipped(const std::string& name, int resolution) { return testing::shipped_scene(name, resolution); }
RenderSettings settings(const std::string& method, std::vector<std::string> params, bool gpu) {
  return testing::device_settings(method, std::move(params), gpu);
}
using testing::mean_abs_dv;

class BaselinesGpu : public GpuTest {
 protected:
  // Renders `scene` with `method` on both devices; returns mean |dV| and checks the GPU's V is
  // not trivially uniform where the CPU's has shadows.
  double difference(const Scene& scene, const std::string& method, const std::vector<std::string>& params) {
    const RenderResult cpu = render_scene(scene, settings(method, params, false));
    const RenderResult gpu = render_scene(scene, settings(method, params, true));
    EXPECT_EQ(gpu.device, device().info().name);
    double shadow = 0;
    for (float v : cpu.visibility.data()) shadow += 1 - v;
    EXPECT_GT(shadow, 10) << "no shadow to compare";
    return mean_abs_dv(cpu.visibility, gpu.visibility);
  }
  void expect_same_pictures(const std::string& scene_file, int resolution) {
    const Scene scene = shipped(scene_file, resolution);
    // Maps of 256 texels keep lavapipe fast; the kernels are the same at any size.
    const std::vector<std::vector<std::string>> cases = {
        {"resolution=256", "pcf=0"},
        {"resolution=256", "pcf=2"},
        {"resolution=256", "pcf=0", "bilinear=false"},
        {"resolution=256", "pcf=1", "bilinear=false"},
    };
    for (const auto& p : cases)
      EXPECT_LE(difference(scene, "shadow-map", p), 1e-3) << scene_file << " " << p[1] << " " << p.back();
    for (const char* variant : {"variant=fernando", "variant=xie2007"})
      EXPECT_LE(difference(scene, "pcss", {"resolution=256", variant, "blocker_samples=16", "pcf_samples=32"}), 1e-3)
          << scene_file << " " << variant;
  }
};

TEST_F(BaselinesGpu, BunnyGivesTheCpuPictures) { expect_same_pictures("bunny.json", 64); }

TEST_F(BaselinesGpu, AlphaMaskedFoliageGivesTheCpuPictures) { expect_same_pictures("foliage.json", 64); }

TEST_F(BaselinesGpu, SemiTransparentFurballGivesTheCpuPictures) { expect_same_pictures("furball.json", 64); }

TEST_F(BaselinesGpu, EveryParameterWorksAsOnTheCpu) {
  const Scene scene = shipped("bunny.json", 48);
  EXPECT_LE(difference(scene, "shadow-map",
                       {"resolution=200", "max_fov=60", "bias=0.01", "slope_bias=2", "max_slope=4",
                        "receiver_plane=false", "pcf=1"}),
            1e-3);
  EXPECT_LE(difference(scene, "pcss",
                       {"resolution=160", "receiver_plane=false", "jitter=false", "blocker_samples=7",
                        "pcf_samples=13", "bias=0.002"}),
            1e-3);
  // A textured light: pcss's light points follow its table on both devices.
  const Scene glass = shipped("stained-glass.json", 48);
  EXPECT_LE(difference(glass, "pcss", {"resolution=128", "blocker_samples=8", "pcf_samples=16"}), 1e-3);
}

TEST_F(BaselinesGpu, NoReceiverInFrontOfTheLightRendersNoMapAndTheCpuPicture) {
  const Scene scene = testing::light_facing_away_scene();  // facing up, away from the ground
  for (const char* method : {"shadow-map", "pcss"}) {
    const RenderResult cpu = render_scene(scene, settings(method, {"resolution=64"}, false));
    const RenderResult gpu = render_scene(scene, settings(method, {"resolution=64"}, true));
    EXPECT_EQ(mean_abs_dv(cpu.visibility, gpu.visibility), 0.0) << method;
    for (float c : gpu.color.data()) ASSERT_EQ(c, 0.0f) << method;  // the light faces away
    EXPECT_TRUE(gpu.gpu_ms.contains("fit")) << method;
    EXPECT_FALSE(gpu.gpu_ms.contains("raster")) << method;
  }
}

TEST_F(BaselinesGpu, StagesAreNamedAndTheMapIsRenderedOnlyWhenTheFittedViewChanges) {
  Scene scene = shipped("bunny.json", 48);
  for (const char* method : {"shadow-map", "pcss"}) {
    // One map (a 128-texel map holds fewer texels than the bunny's triangles: partitions would
    // split it; light_partitions_test.cpp tests those).
    std::vector<std::string> params = {"resolution=128", "partitions=1"};
    if (std::string(method) == "pcss") params.insert(params.end(), {"pcf_samples=8", "blocker_samples=8"});
    Renderer r(scene, settings(method, params, true));
    const RenderResult first = r.render();
    const std::string lookup = std::string(method) == "pcss" ? "filter" : "lookup";
    for (const std::string& stage : {std::string("fit"), std::string("raster"), lookup})
      EXPECT_TRUE(first.gpu_ms.contains(stage)) << method << " " << first.gpu_ms.dump();
    EXPECT_GT(first.stats.texels_visited, 0u);
    EXPECT_EQ(first.stats.extra.at("map_width"), 128);
    // The same view samples: the same fitted view, no new map.
    const RenderResult second = r.render();
    EXPECT_FALSE(second.gpu_ms.contains("raster")) << method << " " << second.gpu_ms.dump();
    EXPECT_EQ(mean_abs_dv(first.visibility, second.visibility), 0.0);
    // Another camera sees other receivers: a new view, a new map.
    Camera cam = scene.camera;
    cam.eye = cam.eye + (cam.target - cam.eye) * 0.3f;
    r.set_camera(cam);
    const RenderResult third = r.render();
    EXPECT_TRUE(third.gpu_ms.contains("raster")) << method << " " << third.gpu_ms.dump();
  }
}

TEST_F(BaselinesGpu, MemoryEstimateCoversWhatTheMethodHolds) {
  const Scene scene = shipped("bunny.json", 32);
  for (const char* method : {"shadow-map", "pcss"}) {
    const MemoryEstimate e = testing::gpu_memory_estimate(method, scene, {"resolution=128"}, 32 * 32);
    EXPECT_GT(testing::gpu_memory_estimate(method, scene, {"resolution=1024"}, 32 * 32).bytes, e.bytes) << method;
    const RenderResult r = render_scene(scene, settings(method, {"resolution=128"}, true));
    EXPECT_GT(r.stats.memory_bytes, 0u);
    EXPECT_LE(r.stats.memory_bytes, e.bytes) << method;
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
