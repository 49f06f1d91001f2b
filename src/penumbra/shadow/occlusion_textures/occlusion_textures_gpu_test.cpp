// `occlusion-textures` on the GPU against its CPU version: the slicing pass's coverage masks (the
// GPU rasterizer's depth-bin mode) equal to the CPU's, also when the rasterizer's buffers are too
// small and grow; the same pictures (mean |dV| at most 2e-3, issue 29) on the bunny and the
// alpha-masked foliage with every prefilter and parameter; the stages, statistics, crops, a
// moved camera and the memory estimate. Small renders: lavapipe is slow.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "penumbra/eval/run_setup.h"
#include "penumbra/gpu/gpu_scene.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/gpu/raster/gpu_depth_bins.h"
#include "penumbra/gpu/raster/gpu_rasterizer.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/occlusion_textures/occlusion_textures.h"
#include "penumbra/testing/gpu_method_runs.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using gpu::testing::GpuTest;
using penumbra::testing::render_on_both;
using penumbra::testing::shipped_scene;

class OcclusionTexturesGpu : public GpuTest {
 protected:
  // The CPU's coverage masks of `scene` at `options` and the GPU rasterizer's of the same slicing
  // (OcclusionTextures::plan, its per-object flags): how many texels differ. `rasterizer` may be
  // one with small buffers.
  size_t differing_masks(const Scene& scene, const occlusion::Options& options, gpu::GpuRasterizer* rasterizer,
                         size_t* covered) {
    occlusion::OcclusionTextures cpu(options);
    MethodStats stats;
    cpu.build(scene, scene.lights[0], &stats);
    EXPECT_TRUE(cpu.has_casters());
    gpu::GpuScene gs(device(), scene);
    gpu::CommandList cl(device());
    const std::vector<uint32_t> flags = cpu.slicing_object_flags(scene);
    gpu::Buffer flag_buf = gpu::make_buffer<uint32_t>(device(), flags, "flags");
    gpu::GpuDepthBinMasks masks;
    std::vector<Vec2f> tile_bins;
    rasterizer->depth_bin_masks(cl, [&] { cl.submit(); }, "slicing", gs, cpu.view(), RasterFilter{},
                                cpu.slicing_bins(&tile_bins), flag_buf.address(), &masks);
    const DepthBinMasks gpu = masks.download();
    const DepthBinMasks& want = cpu.coverage();
    EXPECT_EQ(gpu.width, want.width);
    EXPECT_EQ(gpu.height, want.height);
    size_t differ = 0;
    *covered = 0;
    for (size_t i = 0; i < want.masks.size(); ++i) {
      differ += gpu.masks[i] != want.masks[i];
      *covered += want.masks[i] != 0;
    }
    // The slices' nearest depths (own_slice): the CPU's where both masks agree, bit for bit (the
    // same fragments' depths, the same minimum), 0 in the empty bins.
    EXPECT_EQ(gpu.nearest.size(), want.nearest.size());
    if (gpu.nearest.size() == want.nearest.size() && !want.nearest.empty()) {
      const size_t plane = want.masks.size();
      size_t nearest_differ = 0;
      for (size_t k = 0; k < static_cast<size_t>(options.slices); ++k)
        for (size_t i = 0; i < plane; ++i)
          if (gpu.masks[i] == want.masks[i]) nearest_differ += gpu.nearest[k * plane + i] != want.nearest[k * plane + i];
      EXPECT_LE(nearest_differ, *covered / 1000);
    }
    return differ;
  }
};

occlusion::Options options(int slices, int resolution, bool cull_back_faces = true, int tiles = 1) {
  occlusion::Options o;
  o.slices = slices;
  o.resolution = resolution;
  o.cull_back_faces = cull_back_faces;
  o.tiles = tiles;
  return o;
}

// The forest generator's scene (scenes/forest.json) with few, small trees: a wide scene whose
// fitted light-space tiles are kept, small enough for lavapipe.
Scene small_forest(int resolution) {
  RunSetup setup = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/forest.json");
  setup.apply("resolution", std::to_string(resolution));
  setup.apply("generator.trees", "4");
  setup.apply("generator.leaves", "300");
  return setup.load();
}

TEST_F(OcclusionTexturesGpu, SlicingMasksAreTheCpus) {
  for (const char* name : {"bunny.json", "foliage.json"})
    for (bool cull : {true, false}) {
      const Scene scene = shipped_scene(name, 32);
      gpu::GpuRasterizer r(device());
      size_t covered = 0;
      const size_t differ = differing_masks(scene, options(16, 128, cull), &r, &covered);
      EXPECT_GT(covered, 500u) << name;
      // The CPU's coverage and depths (raster/raster_shared.h): equal but for float rounding of a
      // fragment's depth exactly on a slice plane.
      EXPECT_LE(differ, covered / 1000) << name << " cull_back_faces " << cull;
      RecordProperty(std::string(name) + (cull ? " culled" : " all faces") + ": texels differing / covered",
                     std::to_string(differ) + " / " + std::to_string(covered));
    }
  // Light-space tiles' own slices (DepthBins::tiles): tiles of 16 texels (smaller than the CPU
  // rasterizer's, a bins record per texel there) and of 64.
  for (int tiles : {8, 2}) {
    const Scene scene = shipped_scene("bunny.json", 32);
    gpu::GpuRasterizer r(device());
    size_t covered = 0;
    EXPECT_LE(differing_masks(scene, options(16, 128, true, tiles), &r, &covered), covered / 1000) << tiles;
    EXPECT_GT(covered, 500u);
  }
}

TEST_F(OcclusionTexturesGpu, RasterizerBuffersThatAreTooSmallGrowAndTheMasksAreRenderedAgain) {
  const Scene scene = shipped_scene("bunny.json", 32);
  for (auto [triangles, items] : {std::pair<uint32_t, uint32_t>{16, 1 << 20}, {1 << 20, 16}, {1, 1}}) {
    gpu::GpuRasterizer r(device());
    r.set_capacities_for_testing(triangles, items);
    size_t covered = 0;
    EXPECT_LE(differing_masks(scene, options(12, 128), &r, &covered), covered / 1000) << triangles << " " << items;
    EXPECT_GE(r.attempts(), 2) << triangles << " " << items;
    EXPECT_GT(covered, 500u);
  }
}

TEST_F(OcclusionTexturesGpu, BunnyAndFoliageGiveTheCpuPicturesWithEveryPrefilter) {
  for (const char* name : {"bunny.json", "foliage.json"}) {
    const Scene scene = shipped_scene(name, 48);
    for (const std::vector<std::string>& p : std::vector<std::vector<std::string>>{
             {"resolution=256"},  // nbuffer, the default
             {"resolution=256", "prefilter=mipmap"},
             {"resolution=256", "prefilter=sat"},
             {"resolution=128", "prefilter=sat", "sat_precision=double"}}) {
      const penumbra::testing::DevicePair d = render_on_both(scene, "occlusion-textures", p);
      EXPECT_GT(d.cpu_shadow, 10) << "no shadow to compare";
      EXPECT_LE(d.mean_abs_dv, 2e-3) << name << " " << p.back();
      RecordProperty(std::string(name) + " " + p.back(), penumbra::testing::dv_text(d.mean_abs_dv));
    }
  }
}

TEST_F(OcclusionTexturesGpu, EveryParameterWorksAsOnTheCpu) {
  const Scene scene = shipped_scene("bunny.json", 32);
  for (const std::vector<std::string>& p : std::vector<std::vector<std::string>>{
           {"resolution=64", "slices=7", "combine=sum", "thin_fix=true"},
           {"resolution=128", "slices=32", "combine=max", "fade=0", "open_fade=0", "prefilter=mipmap"},
           {"resolution=64", "cop_distance=3", "cull_planar=false", "cull_back_faces=false", "prefilter=sat"},
           {"resolution=32", "slices=1", "fade=4", "open_fade=2", "thin_fix=true"},
           {"resolution=128", "tiles=8"},
           {"resolution=64", "tiles=2", "prefilter=mipmap", "combine=sum"},
           {"resolution=128", "tiles=16", "prefilter=sat", "thin_fix=true"},
           {"resolution=128", "own_slice=false"}}) {
    const penumbra::testing::DevicePair d = render_on_both(scene, "occlusion-textures", p);
    EXPECT_LE(d.mean_abs_dv, 2e-3) << p[0] << " " << p[1];
  }
}

TEST_F(OcclusionTexturesGpu, AWideSceneGivesTheCpuPictureWithItsFittedTiles) {
  // Issue 34: the fitted light-space tiles are kept on a forest; their slices, the tiles' pieces
  // of each kernel (occlusion_shared.h ot_visibility_tiled) and the CPU's agree.
  const Scene scene = small_forest(48);
  // The fitted tiles are made with the slices alone (own_slice=false); with the own slice one
  // range, its nearest depths at the texture's texels (kept by the slicing pass: the fitted scale
  // here) or at twice them (a pass of their own).
  for (const char* own : {"own_slice=false", "own_slice=true", "own_slice_scale=2"})
    for (const char* prefilter : {"nbuffer", "sat"}) {
      const penumbra::testing::DevicePair d =
          render_on_both(scene, "occlusion-textures", {"resolution=256", std::string("prefilter=") + prefilter, own});
      EXPECT_GT(d.cpu_shadow, 10) << "no shadow to compare";
      EXPECT_LE(d.mean_abs_dv, 2e-3) << prefilter << " " << own;
      RecordProperty(std::string("small forest ") + prefilter + " " + own, penumbra::testing::dv_text(d.mean_abs_dv));
    }
  occlusion::Options alone = options(16, 256, true, 0);
  alone.own_slice = false;
  occlusion::OcclusionTextures cpu(alone);
  MethodStats stats;
  cpu.build(scene, scene.lights[0], &stats);
  EXPECT_GT(cpu.tiles_side(), 1);
}

TEST_F(OcclusionTexturesGpu, TheNearFieldIsTracedAsOnTheCpu) {
  // The forest's leaves under leaves: the light centre's ray over the near field
  // (ot_near_field_length) through the BVH where the CPU traces it through Embree, the slices and
  // the own slice leaving its depth out alike: at 2 texels (the default), at 8 through the fitted
  // tiles' pieces (own_slice off), and at 0. The CPU's pictures, the CPU's count of rays to 0.1%.
  const Scene scene = small_forest(32);
  for (const std::vector<std::string>& p : std::vector<std::vector<std::string>>{
           {"resolution=256", "near_field=2"}, {"resolution=256", "near_field=8", "own_slice=false"},
           {"resolution=256", "near_field=0"}}) {
    const penumbra::testing::DevicePair d = render_on_both(scene, "occlusion-textures", p);
    EXPECT_LE(d.mean_abs_dv, 2e-3) << p[1];
    const double rays = d.cpu.stats.extra.at("near_field_rays").get<double>();
    EXPECT_NEAR(d.gpu.stats.extra.at("near_field_rays").get<double>(), rays, 1e-3 * rays + 1) << p[1];
    if (p[1] == "near_field=0") EXPECT_EQ(rays, 0);
    else EXPECT_GT(rays, 32 * 32 / 10) << p[1];
  }
}

TEST_F(OcclusionTexturesGpu, StagesStatisticsCropsAndAMovedCamera) {
  const Scene scene = shipped_scene("bunny.json", 32);
  Renderer r(scene, penumbra::testing::device_settings("occlusion-textures", {"resolution=128"}, true));
  const RenderResult first = r.render();
  for (const char* stage : {"slicing", "filtering", "shading"})
    EXPECT_TRUE(first.gpu_ms.contains(stage)) << first.gpu_ms.dump();
  EXPECT_GT(first.stats.texels_visited, 0u);
  EXPECT_GT(first.stats.extra.at("lookups").get<uint64_t>(), 0u);
  EXPECT_GT(first.stats.extra.at("slicing_fragments").get<uint64_t>(), 0u);
  EXPECT_EQ(first.stats.extra.at("culled_objects").size(), 1u);  // the ground
  // The memory held is within the estimate the renderer checked.
  const MemoryEstimate e =
      penumbra::testing::gpu_memory_estimate("occlusion-textures", scene, {"resolution=128"}, 32 * 32);
  EXPECT_GT(first.stats.memory_bytes, 0u);
  EXPECT_LE(first.stats.memory_bytes, e.bytes);
  // Another camera: the textures are the light's, kept; the picture is a fresh CPU render's.
  const Camera cam = penumbra::testing::moved_camera(scene.camera, 0.3f);
  r.set_camera(cam);
  const RenderResult moved = r.render();
  EXPECT_FALSE(moved.gpu_ms.contains("slicing")) << moved.gpu_ms.dump();
  const RenderResult cpu = penumbra::testing::cpu_render_with_camera(scene, cam, "occlusion-textures", {"resolution=128"});
  EXPECT_LE(penumbra::testing::mean_abs_dv(cpu.visibility, moved.visibility), 2e-3);
  // A crop: the window's pixels, as the CPU's (the method is tile-exact).
  RenderSettings crop = penumbra::testing::device_settings("occlusion-textures", {"resolution=128"}, true);
  crop.crop = PixelWindow{5, 3, 29, 21};
  RenderSettings crop_cpu = crop;
  crop_cpu.device = {};
  const RenderResult a = render_scene(scene, crop), b = render_scene(scene, crop_cpu);
  EXPECT_EQ(a.visibility.width(), 24);
  EXPECT_LE(penumbra::testing::mean_abs_dv(a.visibility, b.visibility), 2e-3);
}

TEST_F(OcclusionTexturesGpu, ASceneWithoutCastersIsLit) {
  Scene scene;
  scene.objects.push_back(penumbra::testing::object(penumbra::testing::quad_y(0, -2, 2, -2, 2)));
  scene.lights.push_back(penumbra::testing::rect_light_down({0, 1, 0}, 0.5f, 0.5f));
  scene.camera = penumbra::testing::top_camera(16);
  scene.finalize();
  const penumbra::testing::DevicePair d = render_on_both(scene, "occlusion-textures", {"resolution=64"});
  EXPECT_EQ(d.mean_abs_dv, 0.0);
  EXPECT_FALSE(d.gpu.gpu_ms.contains("slicing"));
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
