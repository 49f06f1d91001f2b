// Caster culling (caster_culling.h): a box is outside exactly when one frustum plane has it all
// on its far side, and the culled list renders the very map the whole list renders.
#include "penumbra/raster/caster_culling.h"

#include <gtest/gtest.h>

#include "penumbra/core/rng.h"
#include "penumbra/raster/rasterizer.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

Bounds3f box(Vec3f c, float half) {
  Bounds3f b;
  b.extend(c - Vec3f(half));
  b.extend(c + Vec3f(half));
  return b;
}

TEST(CasterCulling, ABoxIsOutsideWhenOnePlaneHasItAll) {
  // From the origin down -z, 90 degrees, depth 1 to 20.
  const LightView v = LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 90, 64, 64, 1, 20);
  EXPECT_FALSE(box_outside_view(box({0, 0, -5}, 0.5f), v));
  EXPECT_TRUE(box_outside_view(box({0, 0, 5}, 0.5f), v));     // behind the eye
  EXPECT_TRUE(box_outside_view(box({0, 0, -0.3f}, 0.2f), v));  // before near
  EXPECT_TRUE(box_outside_view(box({0, 0, -30}, 1), v));       // beyond far
  EXPECT_TRUE(box_outside_view(box({8, 0, -5}, 1), v));        // right of x = z
  EXPECT_TRUE(box_outside_view(box({-8, 0, -5}, 1), v));
  EXPECT_TRUE(box_outside_view(box({0, 8, -5}, 1), v));        // above
  EXPECT_TRUE(box_outside_view(box({0, -8, -5}, 1), v));
  EXPECT_FALSE(box_outside_view(box({5, 0, -5}, 0.5f), v));    // straddles the right plane
  EXPECT_FALSE(box_outside_view(box({0, 0, -1}, 0.5f), v));    // straddles near
  EXPECT_TRUE(box_outside_view(Bounds3f{}, v));                // empty
  const LightView o = LightView::orthographic({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, -2, 2, -1, 3, 1, 12, 32, 32);
  EXPECT_FALSE(box_outside_view(box({0, 2, -5}, 0.5f), o));
  EXPECT_TRUE(box_outside_view(box({0, -2, -5}, 0.5f), o));
  EXPECT_TRUE(box_outside_view(box({3, 0, -5}, 0.5f), o));
}

TEST(CasterCulling, TheCulledListRendersTheSameMap) {
  // 200 small objects of 30 triangles each (and one of 3000, cut into runs) scattered over a
  // 40 x 40 area; views that see parts of it.
  Rng rng(3434);
  RasterTriangles all;
  auto add_object = [&](uint32_t object, Vec3f c, int n, float spread) {
    for (int i = 0; i < n; ++i) {
      RasterTriangle t;
      for (Vec3f& p : t.p)
        p = c + Vec3f(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f) * spread;
      t.object = object;
      t.prim = static_cast<uint32_t>(i);
      all.list.push_back(t);
    }
  };
  for (uint32_t o = 0; o < 200; ++o)
    add_object(o, {(rng.next_float() - 0.5f) * 40, (rng.next_float() - 0.5f) * 40, -10 - 10 * rng.next_float()}, 30, 1.5f);
  add_object(200, {0, 0, -15}, 3000, 2.0f);
  CasterCulling culling;
  culling.build(all);
  EXPECT_GE(culling.runs(), 203u);
  const std::vector<LightView> views = {
      LightView::frustum({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, -0.3f, 0.1f, -0.2f, 0.3f, 1, 40, 96, 96),
      LightView::frustum({5, 5, 0}, {0, 0, -1}, {0, 1, 0}, 0.1f, 0.5f, -0.4f, 0.0f, 2, 30, 64, 80),
      LightView::orthographic({3, -4, 0}, {0, 0, -1}, {0, 1, 0}, -6, 6, -5, 5, 1, 40, 80, 64),
  };
  Rasterizer raster(16);
  for (const LightView& v : views) {
    std::vector<RasterTriangle> scratch;
    uint64_t culled = 0;
    const RasterTriangleView kept = culling.visible(all, v, scratch, &culled);
    EXPECT_GT(culled, all.size() / 2) << "the view sees a small part";
    EXPECT_EQ(kept.size() + culled, all.size());
    DepthMap whole, part;
    raster.depth_map(all, v, {}, &whole);
    raster.depth_map(kept, v, {}, &part);
    ASSERT_EQ(whole.z.size(), part.z.size());
    int covered = 0;
    for (size_t i = 0; i < whole.z.size(); ++i) {
      EXPECT_EQ(whole.z[i], part.z[i]) << i;
      EXPECT_EQ(whole.opacity[i], part.opacity[i]) << i;
      covered += std::isfinite(whole.z[i]);
    }
    EXPECT_GT(covered, 100);
  }
  // A view that sees everything culls nothing and copies nothing.
  std::vector<RasterTriangle> scratch;
  const LightView wide = LightView::orthographic({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, -30, 30, -30, 30, 1, 40, 16, 16);
  EXPECT_EQ(culling.visible(all, wide, scratch).list.data(), all.list.data());
  EXPECT_TRUE(scratch.empty());
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
