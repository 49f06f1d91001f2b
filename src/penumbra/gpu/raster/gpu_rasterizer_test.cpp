#include "penumbra/gpu/raster/gpu_rasterizer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "penumbra/eval/run_setup.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/raster/raster_triangle.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/scene/shapes.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra::gpu {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::GpuTest;

Scene shipped(const std::string& name, int resolution = 64) {
  RunSetup setup = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name);
  setup.apply("resolution", std::to_string(resolution));
  return setup.load();
}

// A view as the shadow-map methods fit it from the light's centre (fit_shadow_view), to every
// vertex of the scene in front of the light, at most 90 degrees wide.
LightView light_view(const Scene& scene, int resolution) {
  const AreaLight& light = scene.lights[0];
  std::vector<Vec3f> receivers;
  for (const SceneObject& o : scene.objects)
    for (Vec3f p : o.mesh.positions)
      if (dot(p - light.center, light.frame.n) > 0) receivers.push_back(p);
  ShadowViewFit fit;
  fit.resolution = resolution;
  fit.max_fov = 90;
  return fit_shadow_view(light.center, light.frame.n, light.frame.t, receivers, scene.bounds(), fit);
}

struct MapComparison {
  size_t texels = 0, covered = 0, same_triangle = 0, coverage_differs = 0;
  double max_relative_z = 0;  // over texels with the same triangle
  double max_opacity = 0;     // likewise
};

// The GPU's map of `scene` from `view` against the CPU rasterizer's of the same triangles.
class GpuRasterizerTest : public GpuTest {
 protected:
  MapComparison compare(const Scene& scene, const LightView& view, const RasterFilter& filter = {},
                        GpuRasterizer* rasterizer = nullptr) {
    const DepthMap cpu = render_depth_map(gather_raster_triangles(scene), view, filter);
    GpuScene gs(device(), scene);
    GpuRasterizer own(device());
    GpuRasterizer& r = rasterizer ? *rasterizer : own;
    CommandList cl(device());
    GpuDepthMap map;
    r.depth_map(cl, [&] { cl.submit(); }, "raster", gs, view, filter, &map);
    const DepthMap gpu = map.download();
    EXPECT_EQ(gpu.width, cpu.width);
    EXPECT_EQ(gpu.height, cpu.height);
    MapComparison c;
    float z_min = kInfinity;
    for (size_t i = 0; i < cpu.z.size(); ++i) {
      ++c.texels;
      z_min = std::min(z_min, cpu.z[i]);
      const bool a = cpu.triangle[i] != kNoTriangle, b = gpu.triangle[i] != kNoTriangle;
      if (a != b) ++c.coverage_differs;
      if (!a || !b) continue;
      ++c.covered;
      if (cpu.triangle[i] != gpu.triangle[i]) continue;
      ++c.same_triangle;
      c.max_relative_z = std::max<double>(c.max_relative_z, std::abs(cpu.z[i] - gpu.z[i]) / cpu.z[i]);
      c.max_opacity = std::max<double>(c.max_opacity, std::abs(cpu.opacity[i] - gpu.opacity[i]));
      EXPECT_NEAR(gpu.depth[i], cpu.depth[i], 1e-5) << i;
    }
    if (std::isinf(z_min))
      EXPECT_EQ(map.z_min(), z_min);
    else
      EXPECT_NEAR(map.z_min(), z_min, 1e-5 * z_min);
    stats_ = r.stats();
    return c;
  }
  // The bar: the same triangle for at least 99.9% of the texels, z within 1e-5 relative.
  void expect_equal_maps(const MapComparison& c, size_t min_covered) {
    EXPECT_GE(c.covered, min_covered);
    EXPECT_GE(static_cast<double>(c.same_triangle), 0.999 * static_cast<double>(c.covered));
    EXPECT_LE(static_cast<double>(c.coverage_differs), 0.001 * static_cast<double>(c.texels));
    EXPECT_LT(c.max_relative_z, 1e-5);
    EXPECT_LT(c.max_opacity, 1e-5);
  }
  RasterStats stats_;
};

TEST_F(GpuRasterizerTest, BunnyEqualsTheCpuMap) {
  const Scene scene = shipped("bunny.json");
  const MapComparison c = compare(scene, light_view(scene, 128));
  expect_equal_maps(c, 5000);
  EXPECT_EQ(stats_.triangles, scene.triangle_count());
  EXPECT_GT(stats_.fragments, c.covered);  // the depth test saw hidden fragments too
}

TEST_F(GpuRasterizerTest, TrianglesCrossingTheNearPlaneAreClipped) {
  // An eye inside the scene, just above the ground: the ground's two triangles and the bunny's
  // nearest ones reach behind it and cross the near plane.
  const Scene scene = shipped("bunny.json");
  const LightView view = LightView::perspective({0.4f, 0.15f, 0.6f}, {-1, -0.1f, -1}, {0, 1, 0}, 100, 96, 80, 0.05f, 30);
  const MapComparison c = compare(scene, view);
  expect_equal_maps(c, 3000);
  EXPECT_GT(stats_.setup, 0u);
}

TEST_F(GpuRasterizerTest, AGroundFarBeyondTheGuardBandIsClippedToIt) {
  // A ground plane 2 x 10^5 wide under a narrow view: its corners project millions of texels
  // outside the map and are clipped against the guard band; a box on it casts into the map.
  Scene scene;
  scene.objects.push_back(penumbra::testing::object(penumbra::testing::quad_y(0, -1e5f, 1e5f, -1e5f, 1e5f)));
  scene.objects.push_back(penumbra::testing::object(penumbra::testing::box({-0.5f, 0, -0.5f}, {0.5f, 1, 0.5f})));
  scene.lights.push_back(penumbra::testing::rect_light_down({0, 10, 0}, 1, 1));
  scene.finalize();
  const LightView view = LightView::perspective({0.3f, 10, 0.2f}, {0.05f, -1, 0.02f}, {0, 0, -1}, 20, 128, 96, 1, 20);
  const MapComparison c = compare(scene, view);
  expect_equal_maps(c, 128 * 96);  // the ground covers every texel
  // The ground's two triangles were clipped into fans, split into tiles of 16 x 16 texels.
  EXPECT_GE(stats_.bin_entries, (128 / 16) * (96 / 16));
}

TEST_F(GpuRasterizerTest, AlphaMaskedFoliageDropsTheFragmentsInTheHoles) {
  const Scene scene = shipped("foliage.json");
  bool textured = false;
  for (const SceneObject& o : scene.objects) textured = textured || o.material.alpha.active();
  ASSERT_TRUE(textured) << "foliage.json has no alpha texture any more";
  const MapComparison c = compare(scene, light_view(scene, 128));
  expect_equal_maps(c, 3000);
}

TEST_F(GpuRasterizerTest, SemiTransparentFurballKeepsItsOpacities) {
  const Scene scene = shipped("furball.json");
  const MapComparison c = compare(scene, light_view(scene, 96));
  expect_equal_maps(c, 2000);
}

TEST_F(GpuRasterizerTest, CullingAndOpaqueOnlyFiltersAsOnTheCpu) {
  const Scene scene = shipped("furball.json");
  const LightView view = light_view(scene, 64);
  // Faces toward the light (the ground, the hair's lit sides), then away (the hair's far sides).
  for (auto [culling, covered] : {std::pair{FaceCulling::Back, 1000}, std::pair{FaceCulling::Front, 50}}) {
    RasterFilter f;
    f.culling = culling;
    expect_equal_maps(compare(scene, view, f), covered);
  }
  // Opaque casters only: the furball's hair drops out (a few texels of opaque surface are left).
  RasterFilter opaque;
  opaque.opaque_only = true;
  expect_equal_maps(compare(scene, view, opaque), 50);
  const Scene foliage = shipped("foliage.json");
  expect_equal_maps(compare(foliage, light_view(foliage, 64), opaque), 500);
}

TEST_F(GpuRasterizerTest, OrthographicViewsToo) {
  const Scene scene = shipped("bunny.json");
  const LightView view = LightView::orthographic_fitted({0.3f, -1, 0.2f}, {0, 0, -1}, scene.bounds(), 96, 64);
  expect_equal_maps(compare(scene, view), 3000);
}

TEST_F(GpuRasterizerTest, BuffersThatAreTooSmallGrowAndTheMapIsRenderedAgain) {
  const Scene scene = shipped("bunny.json");
  const LightView view = light_view(scene, 96);
  for (auto [triangles, items] : {std::pair<uint32_t, uint32_t>{16, 1 << 20}, {1 << 20, 16}, {1, 1}}) {
    GpuRasterizer r(device());
    r.set_capacities_for_testing(triangles, items);
    expect_equal_maps(compare(scene, view, {}, &r), 3000);
    EXPECT_GE(r.attempts(), 2) << triangles << " " << items;
    // The next render fits at once.
    expect_equal_maps(compare(scene, view, {}, &r), 3000);
    EXPECT_EQ(r.attempts(), 1);
  }
}

TEST_F(GpuRasterizerTest, AViewOfNothingIsAnEmptyMap) {
  const Scene scene = shipped("bunny.json");
  const AreaLight& light = scene.lights[0];
  // Looking away from the scene.
  const LightView view = LightView::perspective(light.center, -light.frame.n, light.frame.t, 60, 32, 32, 0.1f, 10);
  GpuScene gs(device(), scene);
  GpuRasterizer r(device());
  CommandList cl(device());
  GpuDepthMap map;
  r.depth_map(cl, [&] { cl.submit(); }, "raster", gs, view, {}, &map);
  const DepthMap m = map.download();
  for (size_t i = 0; i < m.z.size(); ++i) {
    ASSERT_EQ(m.triangle[i], kNoTriangle);
    ASSERT_EQ(m.z[i], kInfinity);
    ASSERT_EQ(m.opacity[i], 0.0f);
  }
  EXPECT_EQ(map.z_min(), kInfinity);
  EXPECT_EQ(r.stats().fragments, 0u);
}

TEST(GpuRasterizerMemory, ScratchGrowsWithTrianglesAndTheMap) {
  EXPECT_GT(GpuRasterizer::scratch_bytes(1000, 64, 64), GpuRasterizer::scratch_bytes(10, 64, 64));
  EXPECT_GT(GpuRasterizer::scratch_bytes(10, 2048, 2048), GpuRasterizer::scratch_bytes(10, 64, 64));
  EXPECT_EQ(GpuDepthMap::bytes(64, 32), 64u * 32u * 24u + sizeof(shader::RasterView));
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::gpu
