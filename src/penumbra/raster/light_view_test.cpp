#include "penumbra/raster/light_view.h"

#include <gtest/gtest.h>

#include "penumbra/core/error.h"
#include "penumbra/core/rng.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

Vec3f random_in(const Bounds3f& b, Rng& rng) {
  Vec3f d = b.diagonal();
  return b.lo + Vec3f(d.x * rng.next_float(), d.y * rng.next_float(), d.z * rng.next_float());
}

// to_texel must agree with the OpenGL matrices: texel x = (ndc.x + 1) / 2 W, texel y =
// (1 - ndc.y) / 2 H (row 0 at the top), window depth = (ndc.z + 1) / 2.
void expect_matches_matrices(const LightView& v, const Bounds3f& inside) {
  Rng rng(3);
  Mat4 vp = v.view_projection();
  for (int i = 0; i < 200; ++i) {
    Vec3f p = random_in(inside, rng);
    Vec3f ndc = vp.transform_point(p);
    Vec3f t = v.to_texel(p);
    EXPECT_NEAR(t.x, (ndc.x + 1) * 0.5f * v.width(), 1e-3f);
    EXPECT_NEAR(t.y, (1 - ndc.y) * 0.5f * v.height(), 1e-3f);
    EXPECT_NEAR(t.z, v.linear_depth(p), 1e-5f * std::abs(t.z) + 1e-6f);
    EXPECT_NEAR(v.window_depth(t.z), (ndc.z + 1) * 0.5f, 1e-5f);
    // Round trips: the texel ray at that depth is the point; window depth inverts.
    Vec3f back = v.texel_to_world({t.x, t.y}, t.z);
    EXPECT_NEAR(distance(back, p), 0.0f, 1e-4f * (1 + length(p - v.eye())));
    EXPECT_NEAR(v.linear_depth_from_window(v.window_depth(t.z)), t.z, 1e-4f * std::abs(t.z));
  }
}

TEST(LightView, PerspectiveAgreesWithGlMatrices) {
  LightView v = LightView::perspective({1, 2, 3}, {0.2f, -1, -0.3f}, {0, 1, 0}, 50, 300, 200, 0.5f, 40);
  Vec3f f = v.forward();
  Bounds3f b;
  b.extend(Vec3f(1, 2, 3) + f * 5 - Vec3f(1));
  b.extend(Vec3f(1, 2, 3) + f * 5 + Vec3f(1));
  expect_matches_matrices(v, b);
  // The top row looks fov/2 above the axis; rows grow downward.
  LightView::TexelRay top = v.texel_ray({150, 0});
  EXPECT_NEAR(degrees(std::acos(dot(normalize(top.dir), v.forward()))), 25.0f, 1e-3f);
  EXPECT_GT(dot(top.dir, v.up()), 0.0f);
  EXPECT_LT(dot(v.texel_ray({150, 200}).dir, v.up()), 0.0f);
  EXPECT_GT(dot(v.texel_ray({300, 100}).dir, v.right()), 0.0f);
}

TEST(LightView, OffCentreFrustumAndOrthographicAgreeWithGlMatrices) {
  LightView f = LightView::frustum({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, -0.2f, 0.6f, -0.1f, 0.3f, 0.5f, 20, 128, 64);
  Bounds3f b;
  b.extend(Vec3f(0.5f, 0.3f, -3));
  b.extend(Vec3f(1.5f, 1.0f, -4));
  expect_matches_matrices(f, b);
  LightView o = LightView::orthographic({0, 5, 0}, {0, -1, 0}, {0, 0, -1}, -2, 3, -1, 4, -1, 9, 100, 80);
  Bounds3f c;
  c.extend(Vec3f(-1, 0, -1));
  c.extend(Vec3f(2, 4, 3));
  expect_matches_matrices(o, c);
  EXPECT_FLOAT_EQ(o.texel_world_size(1), 5.0f / 100);
}

TEST(LightView, TexelWorldSizeIsTheDistanceBetweenNeighbouringTexelRays) {
  LightView v = LightView::perspective({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, 40, 256, 256, 0.1f, 10);
  for (float z : {0.5f, 2.0f, 7.0f}) {
    float d = distance(v.texel_to_world({128, 128}, z), v.texel_to_world({129, 128}, z));
    EXPECT_NEAR(v.texel_world_size(z), d, 1e-4f * d);
  }
}

TEST(LightView, FittedFrustumContainsTheBoundsTightly) {
  Bounds3f b;
  b.extend({-1, 0, -1});
  b.extend({2, 1.5f, 0.5f});
  Vec3f eye{4, 6, 5};
  LightView v = LightView::frustum_fitted(eye, b.center() - eye, {0, 1, 0}, b, 200, 100, 0.01f);
  float x0 = kInfinity, x1 = -kInfinity, y0 = kInfinity, y1 = -kInfinity;
  for (int i = 0; i < 8; ++i) {
    Vec3f t = v.to_texel(b.corner(i));
    EXPECT_GE(t.x, 0); EXPECT_LE(t.x, 200);
    EXPECT_GE(t.y, 0); EXPECT_LE(t.y, 100);
    EXPECT_GE(t.z, v.near()); EXPECT_LE(t.z, v.far());
    x0 = std::min(x0, t.x); x1 = std::max(x1, t.x);
    y0 = std::min(y0, t.y); y1 = std::max(y1, t.y);
  }
  EXPECT_LT(x0, 0.01f); EXPECT_GT(x1, 199.99f);  // tight on every side
  EXPECT_LT(y0, 0.01f); EXPECT_GT(y1, 99.99f);
}

TEST(LightView, FittedFrustumKeepsThePartBeyondMinNear) {
  // The eye sits inside the box: only the part at depth >= min_near can be seen.
  Bounds3f b;
  b.extend({-1, -1, -1});
  b.extend({1, 1, 1});
  LightView v = LightView::frustum_fitted({0, 0, 0.5f}, {0, 0, -1}, {0, 1, 0}, b, 64, 64, 0.1f);
  EXPECT_FLOAT_EQ(v.near(), 0.1f);
  EXPECT_NEAR(v.far(), 1.5f, 1e-3f);
  Rng rng(5);
  for (int i = 0; i < 500; ++i) {
    Vec3f p = random_in(b, rng);
    Vec3f t = v.to_texel(p);
    if (t.z < 0.1f) continue;
    EXPECT_GE(t.x, 0); EXPECT_LE(t.x, 64);
    EXPECT_GE(t.y, 0); EXPECT_LE(t.y, 64);
  }
  // The widest point: a corner of the box face at depth min_near, x/z = 1/0.1.
  EXPECT_NEAR(-v.window_left() / v.near(), 10.0f, 1e-2f);
  Bounds3f behind;
  behind.extend({-1, -1, 1});
  behind.extend({1, 1, 2});
  EXPECT_THROW(LightView::frustum_fitted({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, behind, 8, 8, 0.1f), Error);
}

TEST(LightView, BoxPartBeyondNearIsTheClippedBoxsVertices) {
  // A box 1 <= z <= 3 in front of an eye looking down the z axis (view frame = world frame).
  Bounds3f b;
  b.extend({-1, -2, 1});
  b.extend({1, 2, 3});
  const Vec3f eye{0, 0, 0}, right{1, 0, 0}, up{0, 1, 0}, forward{0, 0, 1};
  // Wholly beyond the plane: its 8 corners, nothing else.
  BoxPartBeyondNear all = box_part_beyond_near(b, eye, right, up, forward, 0.5f);
  EXPECT_EQ(all.count, 8);
  // Cut at z = 2: the 4 far corners and the 4 crossings of the edges along z, all at z >= 2,
  // spanning x in [-1, 1] and y in [-2, 2].
  BoxPartBeyondNear cut = box_part_beyond_near(b, eye, right, up, forward, 2.0f);
  ASSERT_EQ(cut.count, 8);
  int on_plane = 0;
  for (int i = 0; i < cut.count; ++i) {
    const Vec3f p = cut.points[i];
    EXPECT_GE(p.z, 2.0f);
    EXPECT_EQ(std::abs(p.x), 1.0f);
    EXPECT_EQ(std::abs(p.y), 2.0f);
    on_plane += p.z == 2.0f;
  }
  EXPECT_EQ(on_plane, 4);
  // Wholly before the plane, and an empty box: no points.
  EXPECT_EQ(box_part_beyond_near(b, eye, right, up, forward, 3.5f).count, 0);
  EXPECT_EQ(box_part_beyond_near(Bounds3f{}, eye, right, up, forward, 0.5f).count, 0);
}

TEST(LightView, OrthographicFittedContainsTheBounds) {
  Bounds3f b;
  b.extend({-3, 0, 2});
  b.extend({1, 2, 5});
  LightView v = LightView::orthographic_fitted({0.3f, -1, 0.2f}, {0, 0, 1}, b, 50, 70);
  for (int i = 0; i < 8; ++i) {
    Vec3f t = v.to_texel(b.corner(i));
    EXPECT_GE(t.x, 0); EXPECT_LE(t.x, 50);
    EXPECT_GE(t.y, 0); EXPECT_LE(t.y, 70);
    EXPECT_GT(t.z, v.near()); EXPECT_LT(t.z, v.far());
  }
}

TEST(LightView, RejectsBadParameters) {
  EXPECT_THROW(LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 60, 0, 10, 0.1f, 1), Error);
  EXPECT_THROW(LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 60, 10, 10, 0, 1), Error);
  EXPECT_THROW(LightView::perspective({0, 0, 0}, {0, 0, 0}, {0, 1, 0}, 60, 10, 10, 0.1f, 1), Error);
  EXPECT_THROW(LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 180, 10, 10, 0.1f, 1), Error);
  EXPECT_THROW(LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 60, 20000, 10, 0.1f, 1), Error);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
