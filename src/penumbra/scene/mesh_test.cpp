#include "penumbra/scene/mesh.h"

#include <gtest/gtest.h>

#include "penumbra/scene/shapes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

void expect_near(Vec3f a, Vec3f b, float eps = 1e-5f) {
  EXPECT_NEAR(a.x, b.x, eps);
  EXPECT_NEAR(a.y, b.y, eps);
  EXPECT_NEAR(a.z, b.z, eps);
}

TriangleMesh one_triangle() {
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
  m.indices = {0, 1, 2};
  return m;
}

TEST(TriangleMesh, BoundsCoverAllVertices) {
  TriangleMesh m = make_box({1, 2, 3});
  Bounds3f b = m.bounds();
  expect_near(b.lo, {-0.5f, -1, -1.5f});
  expect_near(b.hi, {0.5f, 1, 1.5f});
  EXPECT_TRUE(TriangleMesh().bounds().empty());
}

TEST(TriangleMesh, TransformMovesPointsAndNormalsByInverseTranspose) {
  TriangleMesh m;
  m.positions = {{1, 1, 0}};
  // A 45-degree plane's normal; under scale (2, 1, 1) the plane x + y = 2 becomes
  // x / 2 + y = 2, whose normal is (1, 2, 0) / sqrt(5), not scale * n.
  m.normals = {normalize(Vec3f(1, 1, 0))};
  m.transform(Mat4::translate({10, 0, 0}) * Mat4::scale({2, 1, 1}));
  expect_near(m.positions[0], {12, 1, 0});
  expect_near(m.normals[0], normalize(Vec3f(1, 2, 0)));

  TriangleMesh r;
  r.positions = {{1, 0, 0}};
  r.transform(Mat4::rotate_z(90));  // counter-clockwise about z: x -> y
  expect_near(r.positions[0], {0, 1, 0});
}

TEST(TriangleMesh, MirrorKeepsOutwardWinding) {
  TriangleMesh box = make_box({1, 1, 1});
  ASSERT_GT(signed_volume(box), 0.99);
  box.transform(Mat4::scale({-1, 1, 1}));
  EXPECT_NEAR(signed_volume(box), 1.0, 1e-5);  // still outward: indices were swapped
  EXPECT_TRUE(box.is_closed());
}

TEST(TriangleMesh, AppendOffsetsIndicesAndFillsOpacity) {
  TriangleMesh a = one_triangle(), b = one_triangle();
  b.triangle_opacity = {0.25f};
  a.append(b);
  ASSERT_EQ(a.triangle_count(), 2u);
  EXPECT_EQ(a.indices[3], 3u);
  EXPECT_EQ(a.indices[5], 5u);
  EXPECT_EQ(a.normals.size(), 6u);
  ASSERT_EQ(a.triangle_opacity.size(), 2u);
  EXPECT_EQ(a.triangle_opacity[0], 1.0f);  // a had none: opaque
  EXPECT_EQ(a.triangle_opacity[1], 0.25f);
  // Mixing a mesh without normals drops them all (flat shading) instead of leaving
  // vertices without one.
  TriangleMesh flat = one_triangle();
  flat.normals.clear();
  a.append(flat);
  EXPECT_TRUE(a.normals.empty());
  EXPECT_EQ(a.triangle_opacity.size(), 3u);
  // Appending to an empty mesh keeps the other's normals.
  TriangleMesh empty;
  empty.append(one_triangle());
  EXPECT_EQ(empty.normals.size(), 3u);
}

TEST(TriangleMesh, ClosedShapes) {
  EXPECT_TRUE(make_box({1, 2, 3}).is_closed());  // 24 vertices: closed after welding
  EXPECT_TRUE(make_uv_sphere(1, 16).is_closed());
  EXPECT_TRUE(make_uv_sphere(1, 3).is_closed());
  EXPECT_FALSE(make_plane({1, 1}).is_closed());
  EXPECT_FALSE(one_triangle().is_closed());
  EXPECT_FALSE(TriangleMesh().is_closed());
}

TEST(TriangleMesh, OpenOrInconsistentMeshesAreNotClosed) {
  TriangleMesh holed = make_box({1, 1, 1});
  holed.indices.resize(holed.indices.size() - 3);  // remove one triangle
  EXPECT_FALSE(holed.is_closed());

  TriangleMesh flipped = make_box({1, 1, 1});
  std::swap(flipped.indices[1], flipped.indices[2]);  // one triangle wound the wrong way
  EXPECT_FALSE(flipped.is_closed());

  TriangleMesh doubled = make_box({1, 1, 1});  // two coincident boxes: edges shared by 4
  doubled.append(make_box({1, 1, 1}));
  EXPECT_FALSE(doubled.is_closed());

  TriangleMesh two = make_box({1, 1, 1});  // two separate closed boxes: closed
  TriangleMesh other = make_box({1, 1, 1});
  other.transform(Mat4::translate({3, 0, 0}));
  two.append(other);
  EXPECT_TRUE(two.is_closed());
}

TEST(Shapes, OutwardWindingAndVolume) {
  EXPECT_NEAR(signed_volume(make_box({1, 2, 3})), 6.0, 1e-5);
  // A UV sphere's volume approaches 4/3 pi r^3 from below.
  double v = signed_volume(make_uv_sphere(2, 64));
  EXPECT_GT(v, 0.98 * 4.0 / 3.0 * kPi * 8);
  EXPECT_LT(v, 4.0 / 3.0 * kPi * 8);
  // The plane faces +y.
  TriangleMesh p = make_plane({2, 4});
  for (size_t t = 0; t < p.triangle_count(); ++t) {
    Vec3f n = cross(p.vertex(t, 1) - p.vertex(t, 0), p.vertex(t, 2) - p.vertex(t, 0));
    EXPECT_GT(n.y, 0);
  }
  expect_near(p.bounds().hi, {1, 0, 2});
}

TEST(Shapes, TubesAreClosedAndOutward) {
  const float r1[1] = {0.1f};
  const Vec3f line[3] = {{0, 0, 0}, {0, 1, 0}, {0.5f, 1.5f, 0}};
  TriangleMesh capped = make_tube(line, r1, 6, false, true);
  EXPECT_TRUE(capped.is_closed());
  EXPECT_GT(signed_volume(capped), 0);
  EXPECT_FALSE(make_tube(line, r1, 6, false, false).is_closed());

  // A closed loop (a circle) without caps: closed, volume ~ 2 pi R * pi r^2.
  std::vector<Vec3f> circle;
  for (int i = 0; i < 200; ++i)
    circle.push_back({std::cos(2 * kPi * i / 200), 0, std::sin(2 * kPi * i / 200)});
  TriangleMesh torus = make_tube(circle, r1, 24, true, false);
  EXPECT_TRUE(torus.is_closed());
  EXPECT_EQ(torus.triangle_count(), 2u * 200 * 24);
  // Pappus: the 24-gon cross-section's area times the centre's path length.
  EXPECT_NEAR(signed_volume(torus), 2 * kPi * (12 * 0.01 * std::sin(2 * kPi / 24)), 1e-3);
  EXPECT_GT(signed_volume(torus), 0);
  // Every ring vertex lies at distance r from the curve (no twist or pinch at the seam).
  for (Vec3f p : torus.positions) {
    float d = std::sqrt(p.x * p.x + p.z * p.z);
    EXPECT_NEAR(std::hypot(d - 1, p.y), 0.1f, 1e-3f);
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
