#include "penumbra/raster/raster_triangle.h"

#include <gtest/gtest.h>

#include "penumbra/scene/scene.h"

namespace penumbra {
namespace {

TEST(RasterTriangles, GatheredFromASceneWithTheirOpacity) {
  Scene scene;
  SceneObject a, b;
  a.mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  a.mesh.indices = {0, 1, 2, 2, 1, 3};
  a.material.opacity = 1;
  b.mesh.positions = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
  b.mesh.indices = {0, 1, 2, 2, 1, 0};
  b.mesh.triangle_opacity = {0.5f, 0.25f};  // strands: per triangle, times the material's
  b.material.opacity = 0.8f;
  scene.objects = {a, b};
  std::vector<RasterTriangle> tris = gather_raster_triangles(scene);
  ASSERT_EQ(tris.size(), 4u);
  EXPECT_EQ(tris[1].object, 0u);
  EXPECT_EQ(tris[1].prim, 1u);
  EXPECT_EQ(tris[1].p[2], Vec3f(1, 1, 0));
  EXPECT_EQ(tris[1].opacity, 1.0f);
  EXPECT_EQ(tris[3].object, 1u);
  EXPECT_EQ(tris[3].prim, 1u);
  EXPECT_EQ(tris[3].p[0], Vec3f(0, 1, 1));
  EXPECT_FLOAT_EQ(tris[2].opacity, 0.4f);
  EXPECT_FLOAT_EQ(tris[3].opacity, 0.2f);
}

}  // namespace
}  // namespace penumbra
