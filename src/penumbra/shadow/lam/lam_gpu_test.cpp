// `lam` on the GPU against its CPU version (issue 29: mean |dV| at most 2e-3 at the same seed and
// spp): the pictures, every parameter, the LDI's statistics, the LDI kept across camera moves (a
// second render costs only the display), batches of every size, rasterizer buffers far too small,
// crops, an empty shadow region, the memory estimate. Small renders: lavapipe is slow.
#include <gtest/gtest.h>

#include <algorithm>

#include "penumbra/gpu/raster/gpu_batch_rasterizer.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/lam/lam_gpu.h"
#include "penumbra/testing/gpu_method_runs.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::mean_abs_dv;
using testing::shipped_scene;

class LamGpu : public testing::GpuMethodTest {
 protected:
  LamGpu() : GpuMethodTest("lam", 12, {"resolution=96"}) {}
  void TearDown() override {
    lam::set_splat_list_capacity_for_testing(0);
    GpuMethodTest::TearDown();
  }
};

TEST_F(LamGpu, BunnyGivesTheCpuPicture) {
  EXPECT_LE(difference(shipped_scene("bunny.json", 48), settings(true), "bunny"), 2e-3);
}

TEST_F(LamGpu, AlphaMaskedFoliageGivesTheCpuPicture) {
  EXPECT_LE(difference(shipped_scene("foliage.json", 48), settings(true), "foliage"), 2e-3);
}

TEST_F(LamGpu, EveryParameterWorksAsOnTheCpu) {
  const Scene scene = shipped_scene("bunny.json", 32);
  EXPECT_LE(difference(scene, settings(true, {"resolution=64", "filter=nearest", "epsilon=0.01", "open_epsilon=0.001"})),
            2e-3);
  EXPECT_LE(difference(scene, settings(true, {"resolution=80", "local_planes=false"})), 2e-3);
  // Two layers a texel: the insertions beyond are dropped and counted, as on the CPU.
  EXPECT_LE(difference(scene, settings(true, {"resolution=64", "max_layers=2"})), 2e-3);
  // The paper's count for every surface (the ground's splats weighted by default).
  EXPECT_LE(difference(scene, settings(true, {"resolution=64", "weighted_splats=false"})), 2e-3);
  // One tolerance for open and closed surfaces: the GPU still tells them apart for the weights.
  EXPECT_LE(difference(scene, settings(true, {"resolution=64", "open_epsilon=0.005"})), 2e-3);
  // The paper's display (nothing traced), and more points traced than by default.
  EXPECT_LE(difference(scene, settings(true, {"resolution=64", "unresolved=umbra"})), 2e-3);
  EXPECT_LE(difference(scene, settings(true, {"resolution=64", "trace_spread=0"})), 2e-3);
}

TEST_F(LamGpu, TheLdiIsTheCpusLayerForLayer) {
  const Scene scene = shipped_scene("foliage.json", 32);
  const RenderResult cpu = render_scene(scene, settings(false));
  const RenderResult gpu = render_scene(scene, settings(true));
  const nlohmann::json& a = cpu.stats.extra.at("ldi");
  const nlohmann::json& b = gpu.stats.extra.at("ldi");
  for (const char* key : {"width", "height", "layers", "nonempty_texels", "max_depth", "dropped_insertions", "window_degrees"})
    EXPECT_EQ(a.at(key), b.at(key)) << key;
  EXPECT_EQ(cpu.stats.extra.at("splats"), gpu.stats.extra.at("splats"));
  EXPECT_EQ(cpu.stats.extra.at("sample_texels"), gpu.stats.extra.at("sample_texels"));
  EXPECT_EQ(cpu.stats.extra.at("depth_complexity"), gpu.stats.extra.at("depth_complexity"));
  EXPECT_EQ(cpu.stats.texels_visited, gpu.stats.texels_visited);
  // The same points traced (the lookups are the CPU's), nearly the same rays (a light point exactly
  // in a closed surface's plane may fall either side on the other device).
  EXPECT_EQ(cpu.stats.extra.at("traced_samples"), gpu.stats.extra.at("traced_samples"));
  EXPECT_GT(cpu.stats.extra.at("traced_samples").get<uint64_t>(), 0u);
  EXPECT_NEAR(static_cast<double>(cpu.stats.rays_traced), static_cast<double>(gpu.stats.rays_traced),
              1e-3 * static_cast<double>(cpu.stats.rays_traced));
}

TEST_F(LamGpu, TheLdiSurvivesACameraMoveAndOnlyTheDisplayRunsAgain) {
  Scene scene = shipped_scene("bunny.json", 32);
  Renderer r(scene, settings(true));
  const RenderResult first = r.render();
  EXPECT_TRUE(first.gpu_ms.contains("precompute")) << first.gpu_ms.dump();
  EXPECT_TRUE(first.gpu_ms.contains("display"));
  Camera cam = scene.camera;
  cam.eye = cam.eye + (cam.target - cam.eye) * 0.3f;
  r.set_camera(cam);
  const RenderResult second = r.render();
  EXPECT_FALSE(second.gpu_ms.contains("precompute")) << second.gpu_ms.dump();
  EXPECT_TRUE(second.gpu_ms.contains("display"));
  EXPECT_EQ(second.stats.prepare_count, 0u);
  // The same picture as a fresh render from there, and the CPU's.
  scene.camera = cam;
  const RenderResult fresh = render_scene(scene, settings(true));
  EXPECT_EQ(mean_abs_dv(second.visibility, fresh.visibility), 0.0);
  const RenderResult cpu = render_scene(scene, settings(false));
  EXPECT_LE(mean_abs_dv(second.visibility, cpu.visibility), 2e-3);
}

TEST_F(LamGpu, BatchesOfEverySizeAndListsAndBuffersFarTooSmallGiveOnePicture) {
  const Scene scene = shipped_scene("foliage.json", 32);
  const RenderResult whole = render_scene(scene, settings(true));
  gpu::GpuBatchRasterizer::set_batch_budget_for_testing(1);  // one light sample a batch
  const RenderResult single = render_scene(scene, settings(true));
  EXPECT_EQ(mean_abs_dv(whole.visibility, single.visibility), 0.0);
  gpu::GpuBatchRasterizer::set_batch_budget_for_testing(0);
  gpu::GpuBatchRasterizer::set_first_capacities_for_testing(2, 3);
  const RenderResult grown = render_scene(scene, settings(true));
  EXPECT_EQ(mean_abs_dv(whole.visibility, grown.visibility), 0.0);
  EXPECT_EQ(whole.stats.extra.at("ldi").at("layers"), grown.stats.extra.at("ldi").at("layers"));
  // Splat lists of one slot: nearly every texel's overflows and it gathers its splats itself.
  gpu::GpuBatchRasterizer::set_first_capacities_for_testing(0, 0);
  lam::set_splat_list_capacity_for_testing(1);
  const RenderResult gathered = render_scene(scene, settings(true));
  EXPECT_EQ(mean_abs_dv(whole.visibility, gathered.visibility), 0.0);
  EXPECT_EQ(whole.stats.extra.at("splats"), gathered.stats.extra.at("splats"));
}

TEST_F(LamGpu, ALightFarFromTheSceneGivesTheCpuPicture) {
  // A sun (100 m wide, 1 km away, 45 degrees up) over a box: both devices' builds and displays take the tolerances
  // the view's width scales (depth_tolerance_scale); lam_test.cpp holds the CPU to the penumbra.
  const Scene scene = testing::ground_scene({testing::object(testing::box({-0.5f, 0, -0.5f}, {0.5f, 1, 0.5f}))},
                                            testing::rect_light_down({700, 700, 0}, 100, 100), 32);
  const RenderResult gpu = render_scene(scene, settings(true));
  EXPECT_LE(difference(scene, settings(true), "sun"), 2e-3);
  // The box's shadow, 1 m long toward -x, is there (the ground read as lit before).
  EXPECT_LT(*std::min_element(gpu.visibility.data().begin(), gpu.visibility.data().end()), 0.05f);
}

TEST_F(LamGpu, CropWindowIsTheWholeFramesPixelsAndTheCpusCrop) {
  // The LDI does not depend on the view samples: the crop is the whole frame's pixels.
  EXPECT_LE(crop_difference(shipped_scene("bunny.json", 48), PixelWindow{8, 12, 40, 36}, /*tile_exact=*/true), 2e-3);
}

TEST_F(LamGpu, AnEmptyShadowRegionGivesTheCpuPicture) {
  // The light faces away from everything: no caster, no layer; closed objects keep their clamp.
  const RenderResult gpu = expect_the_cpus_picture(testing::light_facing_away_scene());
  EXPECT_EQ(gpu.stats.extra.at("ldi").at("layers"), 0);
}

TEST_F(LamGpu, ShadowsBeyondTheRegionsCutAreTracedAsOnTheCpu) {
  // lam_test.cpp's street: its shadows 73-82 degrees off the light's axis lie beyond the region's
  // cut, and the display traces them (lam_beyond_cap, both devices' function).
  const RenderResult gpu = expect_the_cpus_picture(testing::street_beyond_the_cap_scene(32));
  EXPECT_GT(gpu.stats.extra.at("traced_samples").get<uint64_t>(), 0u);
}

TEST_F(LamGpu, MemoryEstimateCoversWhatTheMethodHolds) {
  const Scene scene = shipped_scene("bunny.json", 32);
  const GpuMethodInfo* info = find_gpu_method("lam");
  ASSERT_NE(info, nullptr);
  ASSERT_TRUE(info->estimate_memory);
  MemoryQuery q;
  q.triangles = scene.triangle_count();
  q.view_samples = 32 * 32;
  q.light_samples = 12;
  const MemoryEstimate e = info->estimate_memory(resolve_method_params("lam", scene, {"resolution=96"}), q);
  const RenderResult r = render_scene(scene, settings(true));
  EXPECT_GT(r.stats.memory_bytes, 0u);
  EXPECT_LE(r.stats.memory_bytes, e.bytes);
  EXPECT_GT(info->estimate_memory(resolve_method_params("lam", scene, {"resolution=512"}), q).bytes, e.bytes);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
