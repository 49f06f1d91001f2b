// `coherent-rt` on the GPU against its CPU version (issue 29: mean |dV| at most 2e-3 at the same
// seed and spp on the bunny and the alpha-masked foliage), its parameters, the tile order under
// crops, re-renders, occlusion-span lists too short for the scene, stages, statistics and the
// memory estimate. Small renders: lavapipe is slow, and one thread shades a whole tile.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/coherent_rt/coherent_rt_settings.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/testing/gpu_method_runs.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using gpu::testing::GpuTest;
using testing::mean_abs_dv;
using testing::shipped_scene;

RenderSettings settings(std::vector<std::string> params, bool gpu, int spp = 16) {
  return testing::device_settings("coherent-rt", std::move(params), gpu, 5, spp);
}

class CoherentRtGpu : public GpuTest {
 protected:
  // Mean |dV| between the devices; the colours (E composed) within a few times that relative.
  double difference(const Scene& scene, const std::vector<std::string>& params, int spp = 16) {
    const testing::DevicePair both = testing::render_on_both(scene, settings(params, false, spp));
    EXPECT_EQ(both.gpu.device, device().info().name);
    EXPECT_GT(both.cpu_shadow, 10) << "no shadow to compare";
    const RenderResult& cpu = both.cpu;
    const RenderResult& gpu = both.gpu;
    const double d = both.mean_abs_dv;
    double color = 0, scale = 0;
    for (size_t i = 0; i < cpu.color.data().size(); ++i) {
      color += std::abs(cpu.color.data()[i] - gpu.color.data()[i]);
      scale += std::abs(cpu.color.data()[i]);
    }
    EXPECT_LE(color / std::max(scale, 1e-9), 10 * std::max(d, 1e-4)) << "colours differ more than V";
    // The sampler traced the same share of the cells on both devices.
    EXPECT_NEAR(gpu.stats.extra.at("ray_fraction").get<double>(), cpu.stats.extra.at("ray_fraction").get<double>(),
                0.02);
    std::printf("[ measured ] coherent-rt: mean |dV| %.2e\n", d);
    return d;
  }
};

// Reference images of 256 texels and 16 light cells keep lavapipe fast; the kernels are the same
// at any size.
TEST_F(CoherentRtGpu, BunnyGivesTheCpuPicture) {
  EXPECT_LE(difference(shipped_scene("bunny.json", 48), {"resolution=256"}), 2e-3);
}

TEST_F(CoherentRtGpu, AlphaMaskedFoliageGivesTheCpuPicture) {
  EXPECT_LE(difference(shipped_scene("foliage.json", 48), {"resolution=256"}), 2e-3);
}

TEST_F(CoherentRtGpu, EveryParameterWorksAsOnTheCpu) {
  const Scene scene = shipped_scene("bunny.json", 32);
  EXPECT_LE(difference(scene, {"resolution=128", "coherence=false", "connectedness=true", "views=corners+center"}), 2e-3);
  EXPECT_LE(difference(scene, {"resolution=160", "minmax_clipping=false", "clear_miss=false", "occlusion_intervals=false",
                               "ranking=false", "gap_bias=2", "shadow_bias=1", "slope_bias=0.5", "open_shadow_bias=1"}),
            2e-3);
  EXPECT_LE(difference(scene, {"resolution=128", "shortcut=true", "sub_grid=2", "tile=8", "own_plane=false",
                               "hidden_blocks=true", "views=center", "reset_distance=0.05"}),
            2e-3);
  EXPECT_LE(difference(scene, {"tracer=geometry", "tile=16"}), 2e-3);
  // The paper's rays (no near field) and a near field longer than most rays.
  EXPECT_LE(difference(scene, {"resolution=128", "near_field=0"}), 2e-3);
  EXPECT_LE(difference(scene, {"resolution=64", "near_field=200"}), 2e-3);
}

// 64 light samples a point: on lavapipe more loop iterations than one invocation may run
// (docs/gpu.md), so each tile's work is split over dispatches there; the same picture either way.
TEST_F(CoherentRtGpu, ManyLightSamplesGiveTheCpuPicture) {
  EXPECT_LE(difference(shipped_scene("bunny.json", 16), {"resolution=64", "tile=8"}, 64), 2e-3);
}

TEST_F(CoherentRtGpu, TilesKeepTheCpusOrderUnderCropsAndReRenders) {
  Scene scene = shipped_scene("bunny.json", 48);
  // The paper's rays (no near field): at 128 texels the near field would be whole rays, and the
  // images' walk is what keeps the tiles' order.
  Renderer r(scene, settings({"resolution=128", "tile=16", "near_field=0"}, true, 8));
  const RenderResult first = r.render();
  for (const std::string& stage : {std::string("precompute"), std::string("trace")})
    EXPECT_TRUE(first.gpu_ms.contains(stage)) << first.gpu_ms.dump();
  EXPECT_GT(first.stats.rays_traced, 0u);
  EXPECT_GT(first.stats.texels_visited, 0u);
  EXPECT_GT(first.stats.memory_bytes, 0u);
  // Prepared once: a second render traces the same images, the same picture.
  const RenderResult second = r.render();
  EXPECT_EQ(mean_abs_dv(first.visibility, second.visibility), 0.0);
  // A crop whose edges lie on tile boundaries shades its pixels as the whole frame does, and as
  // the CPU shades that crop; one that cuts tiles as the CPU shades it.
  for (PixelWindow w : {PixelWindow{16, 16, 48, 32}, PixelWindow{5, 9, 37, 30}}) {
    RenderSettings gpu_crop = settings({"resolution=128", "tile=16", "near_field=0"}, true, 8);
    gpu_crop.crop = w;
    RenderSettings cpu_crop = gpu_crop;
    cpu_crop.device = {};
    const RenderResult g = render_scene(scene, gpu_crop);
    const RenderResult c = render_scene(scene, cpu_crop);
    EXPECT_LE(mean_abs_dv(c.visibility, g.visibility), 2e-3) << w.to_string();
  }
  // A camera move: the images are kept, the picture a fresh renderer gives.
  Camera cam = scene.camera;
  cam.eye = cam.eye + (cam.target - cam.eye) * 0.25f;
  r.set_camera(cam);
  const RenderResult moved = r.render();
  Scene moved_scene = scene;
  moved_scene.camera = cam;
  const RenderResult fresh = render_scene(moved_scene, settings({"resolution=128", "tile=16", "near_field=0"}, true, 8));
  EXPECT_EQ(mean_abs_dv(moved.visibility, fresh.visibility), 0.0);
}

TEST_F(CoherentRtGpu, OcclusionSpanListsTooShortGrowAndGiveTheSamePicture) {
  const Scene scene = shipped_scene("foliage.json", 32);
  // The paper's rays (no near field): every ray's whole length walks the images' span lists.
  const RenderResult normal = render_scene(scene, settings({"resolution=128", "near_field=0"}, true, 8));
  coherent_rt::set_first_gpu_span_capacity_for_testing(1);
  const RenderResult grown = render_scene(scene, settings({"resolution=128", "near_field=0"}, true, 8));
  coherent_rt::set_first_gpu_span_capacity_for_testing(0);
  EXPECT_GT(grown.stats.extra.at("span_retries").get<uint64_t>(), 0u) << "no list was too short";
  EXPECT_EQ(mean_abs_dv(normal.visibility, grown.visibility), 0.0);
  EXPECT_EQ(mean_abs_dv(normal.color, grown.color), 0.0);
}

// A disk light's cells (the rect's under the concentric map, soft_shad_shared.h ss_project): the
// same blocker points' prediction on both devices. A sphere light, sampled through its central
// disk facing the scene, E its closed form times V: the CPU's picture and colours.
TEST_F(CoherentRtGpu, DiskAndSphereLightsGiveTheCpuPicture) {
  for (LightShape shape : {LightShape::Disk, LightShape::Sphere}) {
    Scene scene = shipped_scene("bunny.json", 48);
    scene.lights[0].shape = shape;
    scene.lights[0].radius = 0.6f;
    scene.finalize();
    EXPECT_LE(difference(scene, {"resolution=256"}), 2e-3) << to_string(shape);
  }
}

// The light field: the parts of the rays near the light where the lamp's shades lie beyond the
// images, through the BVH as on the CPU through Embree.
TEST_F(CoherentRtGpu, CastersBesideTheLightGiveTheCpuPicture) {
  EXPECT_LE(difference(testing::lamp_shades_scene(40), {"resolution=256"}), 2e-3);
}

TEST_F(CoherentRtGpu, OtherLightShapesAreAOneLineError) {
  Scene scene = shipped_scene("bunny.json", 16);
  scene.lights[0] = testing::ellipsoid_light_down(scene.lights[0].center, {0.4f, 0.3f, 0.2f});
  scene.finalize();
  try {
    render_scene(scene, settings({"resolution=64"}, true, 4));
    FAIL() << "an ellipsoid light rendered";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("only rect, disk and sphere lights"), std::string::npos) << e.what();
  }
}

TEST_F(CoherentRtGpu, MemoryEstimateCoversWhatTheMethodHolds) {
  const Scene scene = shipped_scene("bunny.json", 32);
  const GpuMethodInfo* info = find_gpu_method("coherent-rt");
  ASSERT_NE(info, nullptr);
  ASSERT_TRUE(info->estimate_memory);
  const ParamSet p = resolve_method_params("coherent-rt", scene, {"resolution=128"});
  MemoryQuery q;
  q.triangles = scene.triangle_count();
  q.view_samples = 32 * 32;
  q.light_samples = 8;
  const MemoryEstimate e = info->estimate_memory(p, q);
  const RenderResult r = render_scene(scene, settings({"resolution=128"}, true, 8));
  EXPECT_GE(e.bytes, r.stats.memory_bytes);
  EXPECT_GT(e.bytes, 4u * 128u * 128u * 8u);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
