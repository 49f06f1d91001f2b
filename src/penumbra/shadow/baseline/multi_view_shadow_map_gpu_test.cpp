// `multi-view-sm` on the GPU against its CPU version (issue 30: mean |dV| at most 2e-3 at the same
// seed and spp), in batches of every size, with its rasterizer's buffers far too small, in a crop
// window, without receivers; its stages and its memory estimate. Small renders: lavapipe is slow.
#include <gtest/gtest.h>

#include "penumbra/gpu/raster/gpu_batch_rasterizer.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/testing/gpu_method_runs.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::mean_abs_dv;
using testing::shipped_scene;

class MultiViewGpu : public testing::GpuMethodTest {
 protected:
  MultiViewGpu() : GpuMethodTest("multi-view-sm", 12, {"resolution=96"}) {}
};

TEST_F(MultiViewGpu, BunnyGivesTheCpuPicture) {
  EXPECT_LE(difference(shipped_scene("bunny.json", 48), settings(true), "bunny"), 2e-3);
}

TEST_F(MultiViewGpu, AlphaMaskedFoliageGivesTheCpuPicture) {
  EXPECT_LE(difference(shipped_scene("foliage.json", 48), settings(true), "foliage"), 2e-3);
}

TEST_F(MultiViewGpu, EveryParameterWorksAsOnTheCpu) {
  EXPECT_LE(difference(shipped_scene("bunny.json", 32),
                       settings(true, {"resolution=64", "max_fov=70", "bias=0.004", "slope_bias=2", "max_slope=5",
                                       "receiver_plane=false"})),
            2e-3);
}

TEST_F(MultiViewGpu, TheNearFieldIsTracedAsOnTheCpu) {
  // Coarse maps (24 texels) over the foliage's leaves: most of each shadow ray is the near field
  // (multi_view_shared.h), traced through the BVH as the CPU traces it through Embree; the same
  // rays (the maps and lookups are the CPU's), the CPU's picture. near_field=0: the maps alone.
  const Scene scene = shipped_scene("foliage.json", 32);
  for (const char* near : {"near_field=32", "near_field=0"}) {
    const std::vector<std::string> params = {"resolution=24", near};
    EXPECT_LE(difference(scene, settings(true, params), near), 2e-3) << near;
    const RenderResult gpu = render_scene(scene, settings(true, params));
    const RenderResult cpu = render_scene(scene, settings(false, params));
    const double rays = cpu.stats.extra.at("near_field_rays").get<double>();
    EXPECT_NEAR(gpu.stats.extra.at("near_field_rays").get<double>(), rays, 1e-3 * rays + 1) << near;
    if (std::string(near) == "near_field=0") EXPECT_EQ(rays, 0) << near;
    else EXPECT_GT(rays, 32 * 32) << near;
  }
}

TEST_F(MultiViewGpu, ReceiversBeyondAMapsWindowAreTracedAsOnTheCpu) {
  // Maps 30 degrees wide: the receivers outside a light point's map trace their whole segment to
  // it (multi_view_shared.h mv_traced_length), on both devices.
  EXPECT_LE(difference(shipped_scene("bunny.json", 32), settings(true, {"max_fov=30"})), 2e-3);
}

TEST_F(MultiViewGpu, BatchesOfEverySizeGiveOnePicture) {
  const Scene scene = shipped_scene("bunny.json", 32);
  const RenderResult whole = render_scene(scene, settings(true));
  EXPECT_EQ(whole.stats.extra.at("maps_per_batch"), 12);
  // A budget below one map: a batch per light point, summed in the same order.
  gpu::GpuBatchRasterizer::set_batch_budget_for_testing(1);
  const RenderResult single = render_scene(scene, settings(true));
  EXPECT_EQ(single.stats.extra.at("maps_per_batch"), 1);
  EXPECT_EQ(mean_abs_dv(whole.visibility, single.visibility), 0.0);
  EXPECT_EQ(whole.stats.texels_visited, single.stats.texels_visited);
}

TEST_F(MultiViewGpu, ObjectsOutsideAMapsViewAreCulledAndChangeNothing) {
  // A wide scene: 40 plates along 40 m of ground, the camera above 4 m of it. Each map is fitted
  // to the receivers it shadows, so the plates far away lie outside every map's view: the GPU
  // leaves them out of the set-up (issue 34 part 3), and the picture is the CPU's.
  Scene s;
  s.camera = testing::top_camera(32, 3.0f, 60.0f);
  s.lights.push_back(testing::rect_light_down({0.2f, 2.5f, 0.1f}, 0.8f, 0.6f));
  s.objects.push_back(testing::object(testing::quad_y(0, -20, 20, -3, 3)));
  for (int i = 0; i < 40; ++i) {
    const float x = -20 + i * 1.0f;
    s.objects.push_back(testing::object(testing::quad_y(0.8f + 0.01f * i, x, x + 0.4f, -0.3f, 0.3f)));
  }
  s.finalize();
  EXPECT_LE(difference(s, settings(true), "plates"), 2e-3);
  const RenderResult gpu = render_scene(s, settings(true));
  const RenderResult cpu = render_scene(s, settings(false));
  EXPECT_GT(gpu.stats.extra.at("culled_triangles").get<uint64_t>(), 0u);
  EXPECT_GT(cpu.stats.extra.at("culled_triangles").get<uint64_t>(), 0u);
  // Culled or not, the GPU's maps are the same: every map gives the same lookups.
  EXPECT_EQ(gpu.stats.texels_visited, cpu.stats.texels_visited);
  double shadow = 0;
  for (float v : gpu.visibility.data()) shadow += 1 - v;
  EXPECT_GT(shadow, 10);  // the plates above the camera's patch do cast
}

TEST_F(MultiViewGpu, RasterizerBuffersFarTooSmallGiveTheSamePicture) {
  const Scene scene = shipped_scene("foliage.json", 32);
  const RenderResult fitting = render_scene(scene, settings(true));
  gpu::GpuBatchRasterizer::set_first_capacities_for_testing(2, 3);
  const RenderResult grown = render_scene(scene, settings(true));
  EXPECT_EQ(mean_abs_dv(fitting.visibility, grown.visibility), 0.0);
}

TEST_F(MultiViewGpu, CropWindowGivesTheCpusCrop) {
  // Not tile-exact (the maps are fitted to the rendered view samples), as on the CPU.
  EXPECT_LE(crop_difference(shipped_scene("bunny.json", 48), PixelWindow{8, 12, 40, 36}, /*tile_exact=*/false), 2e-3);
}

TEST_F(MultiViewGpu, NoReceiverInFrontOfTheLightRendersNoMapAndTheCpuPicture) {
  const RenderResult gpu = expect_the_cpus_picture(testing::light_facing_away_scene());
  for (float c : gpu.color.data()) ASSERT_EQ(c, 0.0f);  // the light faces away
  EXPECT_TRUE(gpu.gpu_ms.contains("fit"));
  EXPECT_FALSE(gpu.gpu_ms.contains("raster"));
}

TEST_F(MultiViewGpu, StagesCountersAndMemoryEstimate) {
  const Scene scene = shipped_scene("bunny.json", 32);
  const RenderResult r = render_scene(scene, settings(true));
  for (const char* stage : {"fit", "raster", "lookup"}) EXPECT_TRUE(r.gpu_ms.contains(stage)) << r.gpu_ms.dump();
  const RenderResult cpu = render_scene(scene, settings(false));
  EXPECT_EQ(r.stats.texels_visited, cpu.stats.texels_visited);  // one per receiver and map
  EXPECT_EQ(r.stats.extra.at("map_width"), cpu.stats.extra.at("map_width"));
  const GpuMethodInfo* info = find_gpu_method("multi-view-sm");
  ASSERT_NE(info, nullptr);
  ASSERT_TRUE(info->estimate_memory);
  MemoryQuery q;
  q.triangles = scene.triangle_count();
  q.view_samples = 32 * 32;
  q.light_samples = 12;
  const ParamSet p = resolve_method_params("multi-view-sm", scene, {"resolution=96"});
  const MemoryEstimate e = info->estimate_memory(p, q);
  EXPECT_GT(r.stats.memory_bytes, 0u);
  EXPECT_LE(r.stats.memory_bytes, e.bytes);
  EXPECT_GT(info->estimate_memory(resolve_method_params("multi-view-sm", scene, {"resolution=1024"}), q).bytes, e.bytes);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
