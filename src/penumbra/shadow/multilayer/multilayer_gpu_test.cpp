// `mlsm` and `mtsm` on the GPU against their CPU versions (issue 29: mean |dV| at most 2e-3 at the
// same seed and spp on the bunny and the alpha-masked foliage), the fitted view, crops, re-renders
// after a camera move, stages, statistics and the memory estimate. Small renders: lavapipe is
// slow.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/multilayer/multilayer_map.h"
#include "penumbra/testing/gpu_method_runs.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using gpu::testing::GpuTest;
using testing::mean_abs_dv;
using testing::shipped_scene;

RenderSettings settings(const std::string& method, std::vector<std::string> params, bool gpu, int spp = 16) {
  return testing::device_settings(method, std::move(params), gpu, 3, spp);
}

class MultilayerGpu : public GpuTest {
 protected:
  double difference(const Scene& scene, const std::string& method, const std::vector<std::string>& params,
                    int spp = 16) {
    const testing::DevicePair both = testing::render_on_both(scene, settings(method, params, false, spp));
    EXPECT_EQ(both.gpu.device, device().info().name);
    EXPECT_GT(both.cpu_shadow, 10) << "no shadow to compare";
    const double d = both.mean_abs_dv;
    std::printf("[ measured ] %s: mean |dV| %.2e\n", method.c_str(), d);
    return d;
  }
};

// Maps of 256 texels and 16 light samples keep lavapipe fast; the kernels are the same at any
// size.
TEST_F(MultilayerGpu, BunnyGivesTheCpuPictures) {
  const Scene scene = shipped_scene("bunny.json", 48);
  EXPECT_LE(difference(scene, "mlsm", {"resolution=256"}), 2e-3);
  EXPECT_LE(difference(scene, "mtsm", {"resolution=256"}), 2e-3);
}

TEST_F(MultilayerGpu, AlphaMaskedFoliageGivesTheCpuPictures) {
  const Scene scene = shipped_scene("foliage.json", 48);
  EXPECT_LE(difference(scene, "mlsm", {"resolution=256", "layers=3"}), 2e-3);
  EXPECT_LE(difference(scene, "mtsm", {"resolution=256", "resets=2"}), 2e-3);
}

TEST_F(MultilayerGpu, EveryParameterWorksAsOnTheCpu) {
  const Scene scene = shipped_scene("bunny.json", 32);
  EXPECT_LE(difference(scene, "mlsm",
                       {"resolution=128", "push_back=false", "fit_shadowable=false", "z_thresh=0.01", "self_bias=1",
                        "open_self_bias=0.5", "layers=2", "max_fov=90", "near_field=0", "unresolved=lit"}),
            2e-3);
  EXPECT_LE(difference(scene, "mtsm",
                       {"resolution=160", "z_thresh_texels=2", "error=0", "stop_below=0.01", "resets=0",
                        "open_self_bias=0.05", "near_field=3"}),
            2e-3);
}

// Rays behind full texels (multilayer.md "Rays the map cannot answer for"): one layer per texel
// (mlsm) and no reset (mtsm) in a canopy of 3,000 leaves, without a near field, so that most rays
// are the BVH's to trace whole: the CPU's picture (Embree's), and as many such rays.
TEST_F(MultilayerGpu, RaysBehindFullTexelsAreTracedAsOnTheCpu) {
  const Scene scene = shipped_scene("foliage.json", 40);
  for (const auto& [method, k] : {std::pair{"mlsm", "layers=1"}, std::pair{"mtsm", "resets=0"}}) {
    const testing::DevicePair both =
        testing::render_on_both(scene, settings(method, {"resolution=128", k, "near_field=0"}, false));
    std::printf("[ measured ] %s: mean |dV| %.2e\n", method, both.mean_abs_dv);
    EXPECT_LE(both.mean_abs_dv, 2e-3) << method;
    const auto unresolved = [](const RenderResult& r) {
      return r.stats.extra.at("trace").at("unresolved_rays").get<uint64_t>();
    };
    const uint64_t cpu = unresolved(both.cpu), gpu = unresolved(both.gpu);
    EXPECT_GT(cpu, 1000u) << method << ": the canopy's full texels";
    EXPECT_NEAR(static_cast<double>(gpu), static_cast<double>(cpu), 0.01 * static_cast<double>(cpu)) << method;
  }
}

// A map capped at max_fov: the rays it does not hold are traced whole (ml_leaves_window), the
// GPU's as the CPU's.
TEST_F(MultilayerGpu, RaysTheCappedMapDoesNotHoldAreTracedAsOnTheCpu) {
  Scene scene = testing::ground_scene({testing::object(testing::quad_y(0.9f, 0.3f, 4.0f, -4.0f, 4.0f))},
                                      testing::rect_light_down({0, 1, 0}, 0.5f, 0.5f), 32);
  scene.camera.eye = {-1.5f, 0.6f, 3.0f};  // multilayer_test.cpp's plate beside the light
  scene.camera.target = {2.5f, 0.0f, 0.0f};
  scene.finalize();
  for (const char* method : {"mlsm", "mtsm"}) {
    const testing::DevicePair both = testing::render_on_both(scene, settings(method, {}, false));
    EXPECT_LE(both.mean_abs_dv, 2e-3) << method;
  }
}

// 256 light samples a view sample: on lavapipe more loop iterations than one invocation may run
// (docs/gpu.md), so the traces are split over dispatches there; the same picture either way.
TEST_F(MultilayerGpu, ManyLightSamplesGiveTheCpuPicture) {
  const Scene scene = shipped_scene("bunny.json", 20);
  EXPECT_LE(difference(scene, "mlsm", {"resolution=128"}, 256), 2e-3);
  EXPECT_LE(difference(scene, "mtsm", {"resolution=128"}, 256), 2e-3);
}

TEST_F(MultilayerGpu, SemiTransparentFurballGivesTheCpuPicture) {
  const Scene scene = shipped_scene("furball.json", 32);
  EXPECT_LE(difference(scene, "mtsm", {"resolution=128"}), 2e-3);
}

TEST_F(MultilayerGpu, CropsAndCameraMovesRenderAsFreshRenders) {
  Scene scene = shipped_scene("bunny.json", 40);
  for (const char* method : {"mlsm", "mtsm"}) {
    Renderer r(scene, settings(method, {"resolution=128", "partitions=1"}, true, 8));
    const RenderResult first = r.render();
    for (const std::string& stage : {std::string("build"), std::string("trace")})
      EXPECT_TRUE(first.gpu_ms.contains(stage)) << method << " " << first.gpu_ms.dump();
    EXPECT_GT(first.stats.rays_traced, 0u);
    EXPECT_GT(first.stats.texels_visited, 0u);
    EXPECT_GT(first.stats.memory_bytes, 0u);
    EXPECT_EQ(first.stats.extra.at("map").at("width"), 128) << first.stats.extra.dump();
    // The same view samples: the map is kept, the same picture.
    const RenderResult second = r.render();
    EXPECT_EQ(mean_abs_dv(first.visibility, second.visibility), 0.0) << method;
    // Another camera: a new fit and map, the picture a fresh renderer gives.
    Camera cam = scene.camera;
    cam.eye = cam.eye + (cam.target - cam.eye) * 0.3f;
    r.set_camera(cam);
    const RenderResult moved = r.render();
    Scene moved_scene = scene;
    moved_scene.camera = cam;
    const RenderResult fresh = render_scene(moved_scene, settings(method, {"resolution=128", "partitions=1"}, true, 8));
    EXPECT_EQ(mean_abs_dv(moved.visibility, fresh.visibility), 0.0) << method;
    // A crop: the map fitted to the crop's receivers, as the CPU fits it.
    RenderSettings crop = settings(method, {"resolution=128", "partitions=1"}, true, 8);
    crop.crop = PixelWindow{8, 6, 30, 26};
    RenderSettings crop_cpu = crop;
    crop_cpu.device = {};
    const RenderResult g = render_scene(scene, crop);
    const RenderResult c = render_scene(scene, crop_cpu);
    EXPECT_LE(mean_abs_dv(c.visibility, g.visibility), 2e-3) << method;
  }
}

TEST_F(MultilayerGpu, NoReceiverInFrontOfTheLightGivesTheCpuPicture) {
  Scene scene = shipped_scene("bunny.json", 24);
  AreaLight& light = scene.lights[0];
  light.frame = Frame::from_zx(-light.frame.n, light.frame.s);  // facing away from everything
  scene.finalize();
  for (const char* method : {"mlsm", "mtsm"}) {
    const RenderResult cpu = render_scene(scene, settings(method, {"resolution=64"}, false, 4));
    const RenderResult gpu = render_scene(scene, settings(method, {"resolution=64"}, true, 4));
    EXPECT_EQ(mean_abs_dv(cpu.visibility, gpu.visibility), 0.0) << method;
  }
}

// issue 29: a buffer too small for the scene gives the right result. mtsm's fragment lists (the
// one map whose size the scene decides) start with room for 16 fragments: the lists grow to the
// counted total and render again, and the picture is the one with room enough.
TEST_F(MultilayerGpu, FragmentListsTooSmallGrowAndGiveTheSamePicture) {
  const Scene scene = shipped_scene("foliage.json", 32);
  const RenderResult normal = render_scene(scene, settings("mtsm", {"resolution=128", "partitions=1"}, true, 8));
  multilayer::set_first_gpu_fragment_capacity_for_testing(16);
  const RenderResult grown = render_scene(scene, settings("mtsm", {"resolution=128", "partitions=1"}, true, 8));
  multilayer::set_first_gpu_fragment_capacity_for_testing(0);
  EXPECT_EQ(normal.stats.extra.at("raster_attempts"), 1) << normal.stats.extra.dump();
  EXPECT_GT(grown.stats.extra.at("raster_attempts").get<int>(), 1) << grown.stats.extra.dump();
  EXPECT_GT(grown.stats.extra.at("map").at("fragments").get<uint64_t>(), 16u);
  EXPECT_EQ(mean_abs_dv(normal.visibility, grown.visibility), 0.0);
}

TEST_F(MultilayerGpu, MemoryEstimateCoversWhatTheMethodHolds) {
  const Scene scene = shipped_scene("bunny.json", 32);
  for (const char* method : {"mlsm", "mtsm"}) {
    const GpuMethodInfo* info = find_gpu_method(method);
    ASSERT_NE(info, nullptr) << method;
    ASSERT_TRUE(info->estimate_memory) << method;
    const ParamSet p = resolve_method_params(method, scene, {"resolution=128"});
    MemoryQuery q;
    q.triangles = scene.triangle_count();
    q.view_samples = 32 * 32;
    q.light_samples = 16;
    const MemoryEstimate e = info->estimate_memory(p, q);
    const RenderResult r = render_scene(scene, settings(method, {"resolution=128"}, true, 4));
    EXPECT_GE(e.bytes, r.stats.memory_bytes) << method;
    EXPECT_GT(e.bytes, 128u * 128u * 16u) << method;
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
