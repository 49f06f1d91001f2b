#include "penumbra/raster/raster_triangle.h"

#include <gtest/gtest.h>

#include <memory>

#include "penumbra/scene/scene.h"
#include "penumbra/scene/texture.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

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
  const RasterTriangles tris = gather_raster_triangles(scene);
  ASSERT_EQ(tris.size(), 4u);
  EXPECT_TRUE(tris.textures.empty());
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

TEST(RasterTriangles, AnAlphaTexturedObjectsTrianglesFindTheirTextureInTheSideTable) {
  static_assert(sizeof(RasterTriangle) == 48);
  Scene scene;
  SceneObject plain, leaf;
  plain.mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  plain.mesh.indices = {0, 1, 2};
  leaf.mesh.positions = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}};
  leaf.mesh.indices = {0, 1, 2, 2, 1, 3};
  leaf.mesh.uvs = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};
  // A 2 x 1 texture: opaque on the left half, a hole on the right.
  auto image = std::make_shared<Texture>(2, 1, std::vector<float>{1, 1, 1, 1, 1, 1, 1, 0}, true, "two texels");
  leaf.material.alpha = SurfaceAlpha{image, AlphaMode::Mask, 0.5f};
  leaf.material.opacity = 0.75f;
  scene.objects = {plain, leaf};
  const RasterTriangles tris = gather_raster_triangles(scene);
  ASSERT_EQ(tris.size(), 3u);
  EXPECT_FALSE(tris.textures.empty());
  EXPECT_FALSE(tris.textures.textured(tris[0]));
  EXPECT_TRUE(tris.textures.textured(tris[1]) && tris.textures.textured(tris[2]));
  EXPECT_FALSE(tris.textures.semi_transparent(tris[0]));
  EXPECT_TRUE(tris.textures.semi_transparent(tris[1]));  // opacity 0.75
  // Corner texture coordinates of the second triangle (vertices 2, 1, 3).
  const Vec2f c0 = tris.textures.uv_at(tris[2], 0, 0), c1 = tris.textures.uv_at(tris[2], 1, 0);
  EXPECT_TRUE(c0.x == 0 && c0.y == 1) << c0.x << " " << c0.y;
  EXPECT_TRUE(c1.x == 1 && c1.y == 0) << c1.x << " " << c1.y;
  // A segment down through the left quarter of the quad meets the opaque half; through the
  // right quarter, the hole. The same lines set up once from their origin.
  const RasterTriangle& t = tris[1];
  EXPECT_FLOAT_EQ(tris.textures.opacity_on_segment(t, {0.2f, 0.3f, 2}, {0, 0, -2}), 0.75f);
  EXPECT_EQ(tris.textures.opacity_on_segment(t, {0.7f, 0.1f, 2}, {0, 0, -2}), 0.0f);
  EXPECT_EQ(tris.textures.opacity_on_segment(t, {0.2f, 0.3f, 2}, {0, 0, -0.5f}), 0.0f);  // ends short of it
  const TriangleLines lines(t, {0.4f, 0.4f, 2});
  for (Vec3f dir : {Vec3f(-0.2f, -0.1f, -2), Vec3f(0.3f, -0.3f, -2), Vec3f(0.1f, 0.2f, -1)}) {
    float b1, b2, s, c1, c2, u;
    ASSERT_EQ(lines.crossing(dir, &b1, &b2, &s), t.line_crossing({0.4f, 0.4f, 2}, dir, &c1, &c2, &u));
    EXPECT_EQ(b1, c1);
    EXPECT_EQ(b2, c2);
    EXPECT_EQ(s, u);
    EXPECT_EQ(tris.textures.opacity_on_line(t, lines, dir), tris.textures.opacity_on_line(t, {0.4f, 0.4f, 2}, dir));
  }
  // The untextured view of the same list sees the triangles' plain opacity.
  EXPECT_EQ(RasterTriangleView(tris.list).opacity_on_line(t, {0.7f, 0.1f, 2}, {0, 0, -2}), 0.75f);
  EXPECT_EQ(RasterTriangleView(tris).opacity_on_line(t, {0.7f, 0.1f, 2}, {0, 0, -2}), 0.0f);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
