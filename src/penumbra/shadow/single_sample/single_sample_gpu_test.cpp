// `single-sample` on the GPU against its CPU version (issue 29: mean |dV| at most 2e-3 at the same
// seed): the pictures, every parameter it takes on the GPU, analytic spheres, crops, a camera move
// (the occluders kept), the one-line errors for what it does not take (neighbours, a BVH deeper
// than its stack), the statistics and the memory estimate.
#include <gtest/gtest.h>

#include "penumbra/core/error.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/single_sample/single_sample_gpu.h"
#include "penumbra/testing/gpu_method_runs.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::mean_abs_dv;
using testing::shipped_scene;

class SingleSampleGpu : public testing::GpuMethodTest {
 protected:
  SingleSampleGpu() : GpuMethodTest("single-sample", 16, {}) {}
  void TearDown() override {
    single_sample::set_gpu_stack_levels_for_testing(0);
    GpuMethodTest::TearDown();
  }
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

// The occluder BVH is per light: a camera move searches the uploaded one again, and gives the
// picture a fresh render from there gives.
TEST_F(SingleSampleGpu, TheOccludersSurviveACameraMove) {
  Scene scene = shipped_scene("bunny.json", 32);
  Renderer r(scene, settings(true));
  EXPECT_EQ(r.render().stats.prepare_count, 1u);
  Camera cam = scene.camera;
  cam.eye = cam.eye + (cam.target - cam.eye) * 0.3f;
  r.set_camera(cam);
  const RenderResult moved = r.render();
  EXPECT_EQ(moved.stats.prepare_count, 0u);
  scene.camera = cam;
  EXPECT_EQ(mean_abs_dv(moved.visibility, render_scene(scene, settings(true)).visibility), 0.0);
  EXPECT_LE(mean_abs_dv(moved.visibility, render_scene(scene, settings(false)).visibility), 2e-3);
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

// The search's fixed-size buffer is its stack (one entry a BVH level): an occluder BVH deeper
// than it holds is refused in one line before anything is searched, never searched in part.
TEST_F(SingleSampleGpu, ABvhDeeperThanTheStackIsAOneLineError) {
  const Scene scene = shipped_scene("bunny.json", 32);
  single_sample::set_gpu_stack_levels_for_testing(3);
  Renderer r(scene, settings(true));
  try {
    r.render();
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("levels deep, more than the 3"), std::string::npos) << what;
    EXPECT_NE(what.find("leaf_size"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
  // The refused frame left nothing behind: the same renderer renders the CPU's picture once the
  // stack takes the BVH (what the kernel's stack holds takes the bunny's at the smallest leaves).
  single_sample::set_gpu_stack_levels_for_testing(0);
  EXPECT_LE(mean_abs_dv(r.render().visibility, render_scene(scene, settings(false)).visibility), 2e-3);
  EXPECT_LE(difference(scene, settings(true, {"leaf_size=1"})), 2e-3);
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

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
