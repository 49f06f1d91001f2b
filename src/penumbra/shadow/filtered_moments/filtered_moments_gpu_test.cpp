// `vsm`, `evsm` and `msm` on the GPU against their CPU versions: the same pictures (mean |dV| at
// most 2e-3, issue 30) on the bunny and the alpha-masked foliage with both prefilters and every
// parameter, also when the map's rasterizer starts with buffers far too small; the stages and the
// rebuild rule, a moved camera, the statistics and the memory estimate. Small renders: lavapipe is slow.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/gpu/raster/raster_capacities_testing.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/testing/gpu_method_runs.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using gpu::testing::GpuTest;
using penumbra::testing::DevicePair;
using penumbra::testing::device_settings;
using penumbra::testing::render_on_both;
using penumbra::testing::shipped_scene;

class FilteredMomentsGpu : public GpuTest {
 protected:
  void expect_same_pictures(const std::string& scene_file) {
    const Scene scene = shipped_scene(scene_file, 48);
    for (const char* method : {"vsm", "evsm", "msm"})
      for (const char* prefilter : {"prefilter=sat", "prefilter=mipmap"}) {
        const DevicePair d = render_on_both(scene, method, {"resolution=256", prefilter});
        EXPECT_GT(d.cpu_shadow, 10) << "no shadow to compare";
        EXPECT_LE(d.mean_abs_dv, 2e-3) << scene_file << " " << method << " " << prefilter;
        RecordProperty(scene_file + " " + method + " " + prefilter, penumbra::testing::dv_text(d.mean_abs_dv));
      }
  }
};

TEST_F(FilteredMomentsGpu, BunnyGivesTheCpuPictures) { expect_same_pictures("bunny.json"); }

TEST_F(FilteredMomentsGpu, AlphaMaskedFoliageGivesTheCpuPictures) { expect_same_pictures("foliage.json"); }

TEST_F(FilteredMomentsGpu, EveryParameterWorksAsOnTheCpu) {
  const Scene scene = shipped_scene("bunny.json", 32);
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {"vsm", {"resolution=128", "blocker_search=false", "filter_size=6", "bleeding=0.2", "min_variance=1e-4"}},
      {"vsm", {"resolution=160", "max_fov=60", "min_filter=3", "bias=0.01"}},
      {"evsm", {"resolution=128", "components=2", "positive_exponent=20", "prefilter=mipmap"}},
      {"evsm", {"resolution=128", "negative_exponent=12", "bleeding=0.1", "blocker_search=false"}},
      {"msm", {"resolution=128", "quantize=false", "moment_bias=1e-3"}},
      {"msm", {"resolution=96", "bleeding=0.3", "blocker_search=false", "filter_size=2"}},
  };
  for (const auto& [method, params] : cases)
    EXPECT_LE(render_on_both(scene, method, params).mean_abs_dv, 2e-3) << method << " " << params[1];
}

TEST_F(FilteredMomentsGpu, TheNearFieldIsTracedAsOnTheCpu) {
  // The plant's leaves under leaves: the light centre's ray over the near field
  // (fm_near_field_length) through the BVH where the CPU traces it through Embree, at 2 texels (the
  // default) for each method, and 8 and 0 for vsm: the CPU's pictures, the CPU's count of rays to
  // 0.1%.
  const Scene scene = shipped_scene("plant.json", 32);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"vsm", "near_field=2"}, {"evsm", "near_field=2"}, {"msm", "near_field=2"},
      {"vsm", "near_field=8"}, {"vsm", "near_field=0"}};
  for (const auto& [method, near] : cases) {
    const DevicePair d = render_on_both(scene, method, {"resolution=256", near});
    EXPECT_LE(d.mean_abs_dv, 2e-3) << method << " " << near;
    const double rays = d.cpu.stats.extra.at("near_field_rays").get<double>();
    EXPECT_NEAR(d.gpu.stats.extra.at("near_field_rays").get<double>(), rays, 1e-3 * rays + 1) << method << " " << near;
    if (near == "near_field=0") EXPECT_EQ(rays, 0) << method;
    else EXPECT_GT(rays, 32 * 32 / 10) << method << " " << near;
  }
}

TEST_F(FilteredMomentsGpu, RasterizerBuffersThatAreTooSmallGrowAndThePicturesAreTheCpus) {
  // The moment map's set-up triangles and work items (the only buffers that grow with the scene)
  // start at one each: the rasterizer must grow them and render the map again, dropping nothing.
  for (const char* name : {"bunny.json", "foliage.json"}) {
    const Scene scene = shipped_scene(name, 32);
    for (const char* method : {"vsm", "evsm", "msm"}) {
      const gpu::RasterCapacitiesForTesting tiny(1, 1);
      const DevicePair d = render_on_both(scene, method, {"resolution=128"});
      EXPECT_GE(tiny.retries(), 1) << name << " " << method;
      EXPECT_GT(d.cpu_shadow, 10) << "no shadow to compare";
      EXPECT_LE(d.mean_abs_dv, 2e-3) << name << " " << method;
    }
  }
}

TEST_F(FilteredMomentsGpu, StagesAndTheMomentsAreBuiltOnlyWhenTheMapIsRenderedAgain) {
  // One map (a 128² map would split the bunny's 70 k casters into partitions, each its own map).
  const Scene scene = shipped_scene("bunny.json", 32);
  for (const char* method : {"vsm", "msm"}) {
    Renderer r(scene, device_settings(method, {"resolution=128", "partitions=1"}, true));
    const RenderResult first = r.render();
    for (const char* stage : {"fit", "raster", "prefilter", "filter"})
      EXPECT_TRUE(first.gpu_ms.contains(stage)) << method << " " << first.gpu_ms.dump();
    EXPECT_GT(first.stats.texels_visited, 0u);
    EXPECT_GT(first.stats.extra.at("filtered_lookups").get<uint64_t>(), 0u);
    EXPECT_TRUE(first.stats.extra.contains("samples_without_blockers"));
    EXPECT_EQ(first.stats.extra.at("map_width"), 128);
    // The same view samples: the same fitted view, no new map, no new moments.
    const RenderResult second = r.render();
    EXPECT_FALSE(second.gpu_ms.contains("prefilter")) << second.gpu_ms.dump();
    EXPECT_EQ(penumbra::testing::mean_abs_dv(first.visibility, second.visibility), 0.0);
    // Another camera: a new view, a new map and new moments, the CPU's picture of it.
    const Camera cam = penumbra::testing::moved_camera(scene.camera, 0.3f);
    r.set_camera(cam);
    const RenderResult moved = r.render();
    EXPECT_TRUE(moved.gpu_ms.contains("prefilter")) << moved.gpu_ms.dump();
    const RenderResult cpu =
        penumbra::testing::cpu_render_with_camera(scene, cam, method, {"resolution=128", "partitions=1"});
    EXPECT_LE(penumbra::testing::mean_abs_dv(cpu.visibility, moved.visibility), 2e-3) << method;
  }
}

TEST_F(FilteredMomentsGpu, NoReceiverInFrontOfTheLightIsDarkAsOnTheCpu) {
  const Scene scene = penumbra::testing::light_facing_away_scene();
  for (const char* method : {"vsm", "evsm", "msm"}) {
    const DevicePair d = render_on_both(scene, method, {"resolution=64"});
    EXPECT_EQ(d.mean_abs_dv, 0.0) << method;
    EXPECT_FALSE(d.gpu.gpu_ms.contains("prefilter")) << method;
  }
}

TEST_F(FilteredMomentsGpu, MemoryEstimateCoversWhatTheMethodHolds) {
  const Scene scene = shipped_scene("bunny.json", 32);
  for (const char* method : {"vsm", "evsm", "msm"})
    for (const char* prefilter : {"prefilter=sat", "prefilter=mipmap"}) {
      const MemoryEstimate e =
          penumbra::testing::gpu_memory_estimate(method, scene, {"resolution=128", prefilter}, 32 * 32);
      EXPECT_GT(penumbra::testing::gpu_memory_estimate(method, scene, {"resolution=1024", prefilter}, 32 * 32).bytes,
                e.bytes);
      const RenderResult r = render_scene(scene, device_settings(method, {"resolution=128", prefilter}, true));
      EXPECT_GT(r.stats.memory_bytes, 0u);
      EXPECT_LE(r.stats.memory_bytes, e.bytes) << method << " " << prefilter;
    }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
