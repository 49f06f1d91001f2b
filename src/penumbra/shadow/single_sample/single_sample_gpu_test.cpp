// `single-sample` on the GPU against its CPU version (issue 29: mean |dV| at most 2e-3 at the same
// seed): the pictures, every parameter it takes on the GPU, analytic spheres, crops, the one-line
// error for what it does not take, the statistics and the memory estimate.
#include <gtest/gtest.h>

#include "penumbra/core/error.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/testing/gpu_method_runs.h"

namespace penumbra {
namespace {

using testing::shipped_scene;

class SingleSampleGpu : public testing::GpuMethodTest {
 protected:
  SingleSampleGpu() : GpuMethodTest("single-sample", 16, {}) {}
};

TEST_F(SingleSampleGpu, BunnyGivesTheCpuPicture) {
  EXPECT_LE(difference(shipped_scene("bunny.json", 48), settings(true), "bunny"), 2e-3);
}

TEST_F(SingleSampleGpu, AlphaMaskedFoliageGivesTheCpuPicture) {
  EXPECT_LE(difference(shipped_scene("foliage.json", 48), settings(true), "foliage"), 2e-3);
}

TEST_F(SingleSampleGpu, AnalyticSpheresAndTouchingCastersGiveTheCpuPicture) {
  EXPECT_LE(difference(shipped_scene("contact.json", 48), settings(true), "contact"), 2e-3);
}

TEST_F(SingleSampleGpu, EveryParameterWorksAsOnTheCpu) {
  const Scene scene = shipped_scene("bunny.json", 32);
  for (const std::vector<std::string>& p :
       std::vector<std::vector<std::string>>{{"candidates=all"},
                                             {"combine=multiply"},
                                             {"combine=add", "candidates=all"},
                                             {"diameter=diagonal", "diameter_scale=0.5"},
                                             {"band=0.5", "leaf_size=2", "packet=1"},
                                             {"diameter_scale=0"}})
    EXPECT_LE(difference(scene, settings(true, p)), 2e-3) << p[0];
}

TEST_F(SingleSampleGpu, CropWindowIsTheWholeFramesPixels) {
  EXPECT_LE(crop_difference(shipped_scene("bunny.json", 48), PixelWindow{8, 12, 40, 36}, /*tile_exact=*/true), 2e-3);
}

TEST_F(SingleSampleGpu, NeighboursAreAOneLineErrorBeforeAnythingRuns) {
  const Scene scene = shipped_scene("bunny.json", 16);
  try {
    render_scene(scene, settings(true, {"neighbours=true"}));
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("neighbours"), std::string::npos) << what;
    EXPECT_NE(what.find("--device cpu"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

TEST_F(SingleSampleGpu, StatisticsAndMemoryEstimate) {
  const Scene scene = shipped_scene("bunny.json", 32);
  const RenderResult gpu = render_scene(scene, settings(true));
  const RenderResult cpu = render_scene(scene, settings(false));
  EXPECT_TRUE(gpu.gpu_ms.contains("shadow rays")) << gpu.gpu_ms.dump();
  EXPECT_EQ(gpu.stats.rays_traced, cpu.stats.rays_traced);
  EXPECT_EQ(gpu.stats.extra.at("occluder_triangles"), cpu.stats.extra.at("occluder_triangles"));
  EXPECT_NEAR(gpu.stats.extra.at("hard_blocked_fraction").get<double>(),
              cpu.stats.extra.at("hard_blocked_fraction").get<double>(), 0.01);
  const GpuMethodInfo* info = find_gpu_method("single-sample");
  ASSERT_NE(info, nullptr);
  MemoryQuery q;
  q.triangles = scene.triangle_count();
  q.view_samples = 32 * 32;
  const MemoryEstimate e = info->estimate_memory(resolve_method_params("single-sample", scene, {}), q);
  EXPECT_GT(gpu.stats.memory_bytes, 0u);
  EXPECT_LE(gpu.stats.memory_bytes, e.bytes);
}

}  // namespace
}  // namespace penumbra
