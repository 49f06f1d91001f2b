#include "penumbra/gpu/raster/gpu_batch_rasterizer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "penumbra/eval/run_setup.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/gpu/raster/object_culling.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra::gpu {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::GpuTest;

Scene shipped(const std::string& name) {
  RunSetup setup = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name);
  setup.apply("resolution", "32");
  return setup.load();
}

// Views from a few points of the scene's light, each fitted to every vertex in front of it (as
// multi-view-sm fits one per light sample), `resolution` texels along the longer side.
std::vector<LightView> light_point_views(const Scene& scene, int count, int resolution) {
  const AreaLight& light = scene.lights[0];
  const std::vector<Vec3f> receivers = penumbra::testing::vertices_in_front_of(scene, light);
  ShadowViewFit fit;
  fit.resolution = resolution;
  fit.max_fov = 100;
  std::vector<LightView> views;
  for (int i = 0; i < count; ++i) {
    const Vec2f u((i + 0.5f) / count, (i * 7 % count + 0.5f) / count);
    // Different sizes too: the batch's views need not match.
    fit.resolution = resolution - 9 * i;
    views.push_back(fit_shadow_view(light.sample_area(u), light.frame.n, light.frame.t, receivers, scene.bounds(), fit));
  }
  return views;
}

class GpuBatchRasterizerTest : public GpuTest {
 protected:
  // Every map of the batch against the one mode's map of the same view: the same nearest surface
  // (key: depth bits and triangle) in every texel, and the same opacity.
  void expect_one_mode_maps(const Scene& scene, const GpuDepthMapBatch& batch) {
    GpuScene gs(device(), scene);
    GpuRasterizer one(device());
    CommandList cl(device());
    for (int i = 0; i < batch.count(); ++i) {
      GpuDepthMap map;
      one.depth_map(cl, [&] { cl.submit(); }, "raster", gs, batch.view(i), RasterFilter{}, &map);
      const DepthMap expected = map.download();
      const DepthMap got = batch.download(i);
      ASSERT_EQ(got.width, expected.width);
      ASSERT_EQ(got.height, expected.height);
      size_t differ = 0, covered = 0;
      for (size_t t = 0; t < expected.z.size(); ++t) {
        covered += expected.triangle[t] != kNoTriangle;
        differ += got.triangle[t] != expected.triangle[t] || got.z[t] != expected.z[t] ||
                  (batch.resolved() && got.opacity[t] != expected.opacity[t]);
      }
      EXPECT_GT(covered, expected.z.size() / 10) << "view " << i << " sees little";
      EXPECT_EQ(differ, 0u) << "view " << i;
    }
  }

  GpuDepthMapBatch render(const Scene& scene, const GpuScene& gs, GpuBatchRasterizer& r,
                          const std::vector<LightView>& views, bool resolve, const RasterOutlineCull* cull = nullptr) {
    CommandList cl(device());
    GpuDepthMapBatch batch;
    r.depth_maps(cl, [&] { cl.submit(); }, "raster", gs, views, RasterFilter{}, resolve, &batch, cull);
    return batch;
  }
};

TEST_F(GpuBatchRasterizerTest, EveryViewOfABatchIsTheOneModesMap) {
  for (const char* name : {"bunny.json", "foliage.json"}) {
    SCOPED_TRACE(name);
    const Scene scene = shipped(name);
    GpuScene gs(device(), scene);
    GpuBatchRasterizer r(device());
    const std::vector<LightView> views = light_point_views(scene, 5, 96);
    const GpuDepthMapBatch resolved = render(scene, gs, r, views, true);
    EXPECT_EQ(r.attempts(), 1);
    EXPECT_EQ(resolved.count(), 5);
    EXPECT_GT(r.stats().fragments, 0u);
    expect_one_mode_maps(scene, resolved);
    // Keys only: the same depths and triangles.
    expect_one_mode_maps(scene, render(scene, gs, r, views, false));
  }
}

TEST_F(GpuBatchRasterizerTest, BuffersFarTooSmallGrowAndTheMapsStayTheSame) {
  const Scene scene = shipped("foliage.json");
  GpuScene gs(device(), scene);
  GpuBatchRasterizer r(device());
  const std::vector<LightView> views = light_point_views(scene, 4, 80);
  r.set_capacities_for_testing(3, 5);
  const GpuDepthMapBatch batch = render(scene, gs, r, views, true);
  EXPECT_GT(r.attempts(), 1);
  expect_one_mode_maps(scene, batch);
  // The grown buffers serve the next batch at once.
  render(scene, gs, r, views, true);
  EXPECT_EQ(r.attempts(), 1);
}

TEST_F(GpuBatchRasterizerTest, CullingBackFacesOfClosedMeshesAgainstTheLightKeepsTheMaps) {
  const Scene scene = shipped("bunny.json");
  GpuScene gs(device(), scene);
  GpuBatchRasterizer r(device());
  const std::vector<LightView> views = light_point_views(scene, 3, 96);
  const GpuDepthMapBatch all = render(scene, gs, r, views, false);
  const size_t setup_all = r.stats().setup;
  RasterOutlineCull cull;
  cull.outline = scene.lights[0].outline(32);
  for (const SceneObject& o : scene.objects) {
    // Outward or inward windings, from the signed volume.
    double volume = 0;
    for (size_t t = 0; t < o.mesh.triangle_count(); ++t)
      volume += dot(o.mesh.vertex(t, 0), cross(o.mesh.vertex(t, 1), o.mesh.vertex(t, 2)));
    cull.orientation.push_back(o.closed ? (volume > 0 ? 1.0f : -1.0f) : 0.0f);
  }
  const GpuDepthMapBatch culled = render(scene, gs, r, views, false, &cull);
  EXPECT_LT(r.stats().setup, setup_all * 3 / 4) << "the bunny's back faces are culled";
  for (int i = 0; i < all.count(); ++i) {
    const DepthMap a = all.download(i), b = culled.download(i);
    size_t differ = 0;
    for (size_t t = 0; t < a.z.size(); ++t) differ += a.z[t] != b.z[t];
    EXPECT_LE(differ, a.z.size() / 1000) << "view " << i;
  }
}

TEST_F(GpuBatchRasterizerTest, PerViewCullingOfObjectsOutsideAViewKeepsTheMaps) {
  // Plates along 20 m of ground under a light; one view sees all of them, two narrow views a
  // plate each. ObjectCulling's per-view flags leave the other plates out of the narrow views'
  // set-up, and every map stays the one all objects give, texel for texel.
  Scene scene;
  scene.camera = penumbra::testing::top_camera(32);
  scene.lights.push_back(penumbra::testing::rect_light_down({0, 6, 0}, 1, 1));
  scene.objects.push_back(penumbra::testing::object(penumbra::testing::quad_y(0, -10, 10, -2, 2)));
  for (int i = 0; i < 20; ++i)
    scene.objects.push_back(penumbra::testing::object(penumbra::testing::quad_y(1.0f, -10 + i * 1.0f, -9.6f + i * 1.0f, -0.3f, 0.3f)));
  scene.finalize();
  GpuScene gs(device(), scene);
  GpuBatchRasterizer r(device());
  const Vec3f eye = scene.lights[0].center;
  std::vector<LightView> views = {
      LightView::perspective(eye, normalize(Vec3f(0, -1, 0)), {1, 0, 0}, 150, 96, 96, 0.5f, 20),
      LightView::perspective(eye, normalize(Vec3f(0.2f, -6, 0)), {1, 0, 0}, 8, 64, 64, 0.5f, 20),
      LightView::perspective(eye, normalize(Vec3f(-4.2f, -6, 0)), {1, 0, 0}, 8, 64, 64, 0.5f, 20)};
  ObjectCulling culling;
  culling.prepare(device(), scene);
  RasterViewCulling flags;
  uint64_t culled = 0;
  ASSERT_TRUE(culling.flags_for_views(views, &flags, &culled));
  EXPECT_EQ(flags.flags.size(), views.size() * scene.objects.size());
  for (size_t i = 0; i < scene.objects.size(); ++i) EXPECT_EQ(flags.flags[i], 0u) << "the wide view keeps object " << i;
  EXPECT_GT(culled, 30u);  // most plates outside each narrow view (2 triangles a plate)
  const GpuDepthMapBatch all = render(scene, gs, r, views, true);
  const size_t setup_all = r.stats().setup;
  CommandList cl(device());
  GpuDepthMapBatch batch;
  r.depth_maps(cl, [&] { cl.submit(); }, "raster", gs, views, RasterFilter{}, true, &batch, nullptr, &flags);
  EXPECT_LT(r.stats().setup, setup_all);
  for (int i = 0; i < all.count(); ++i) {
    const DepthMap a = all.download(i), b = batch.download(i);
    EXPECT_EQ(a.z, b.z) << "view " << i;
    size_t covered = 0;
    for (float z : a.z) covered += std::isfinite(z);
    EXPECT_GT(covered, 0u) << "view " << i;
  }
  // A table of the wrong size is an error, not a read past its end.
  flags.flags.pop_back();
  EXPECT_THROW(r.depth_maps(cl, [&] { cl.submit(); }, "raster", gs, views, RasterFilter{}, true, &batch, nullptr, &flags),
               Error);
}

TEST_F(GpuBatchRasterizerTest, BatchSizeFollowsTheBudget) {
  EXPECT_EQ(GpuBatchRasterizer::batch_size(1000, 64 * 64, true, 256, 1), 1);
  EXPECT_EQ(GpuBatchRasterizer::batch_size(1000, 64 * 64, true, 7, uint64_t{1} << 40), 7);
  const int n = GpuBatchRasterizer::batch_size(100000, 512 * 512, true, 256, uint64_t{256} << 20);
  EXPECT_GT(n, 1);
  EXPECT_LT(n, 256);
  EXPECT_LE(GpuDepthMapBatch::bytes(n * 512 * 512, n, true) + GpuBatchRasterizer::scratch_bytes(100000, n, n * 512 * 512),
            uint64_t{256} << 20);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::gpu
