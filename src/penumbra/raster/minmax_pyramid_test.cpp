#include "penumbra/raster/minmax_pyramid.h"

#include <gtest/gtest.h>

#include <vector>

#include "penumbra/core/rng.h"
#include "penumbra/raster/rasterizer.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// Every node must equal the min/max over the level-0 texels it covers (so it bounds each
// child and each texel below), and contain each of its children's ranges.
void expect_bounds_everything_below(const MinMaxPyramid& pyr, const std::vector<DepthRange>& texels) {
  const int W = pyr.width(0);
  for (int l = 0; l < pyr.levels(); ++l)
    for (int y = 0; y < pyr.height(l); ++y)
      for (int x = 0; x < pyr.width(l); ++x) {
        int x0, y0, x1, y1;
        pyr.texels(l, x, y, &x0, &y0, &x1, &y1);
        ASSERT_LT(x0, x1);
        ASSERT_LT(y0, y1);
        DepthRange want;
        for (int ty = y0; ty < y1; ++ty)
          for (int tx = x0; tx < x1; ++tx) want.extend(texels[size_t(ty) * W + tx]);
        DepthRange got = pyr.range(l, x, y);
        ASSERT_EQ(got.lo, want.lo) << "level " << l << " node " << x << "," << y;
        ASSERT_EQ(got.hi, want.hi) << "level " << l << " node " << x << "," << y;
        if (l == 0) continue;
        for (int cy = 2 * y; cy < std::min(2 * y + 2, pyr.height(l - 1)); ++cy)
          for (int cx = 2 * x; cx < std::min(2 * x + 2, pyr.width(l - 1)); ++cx) {
            DepthRange c = pyr.range(l - 1, cx, cy);
            if (c.empty()) continue;
            ASSERT_LE(got.lo, c.lo);
            ASSERT_GE(got.hi, c.hi);
          }
      }
}

TEST(MinMaxPyramid, NonPowerOfTwoLevelsBoundEveryTexelBelow) {
  const int W = 37, H = 23;
  Rng rng(4);
  std::vector<DepthRange> texels(W * H);
  for (auto& t : texels) {
    if (rng.next_float() < 0.3f) continue;  // empty
    float a = 10 * rng.next_float(), b = a + rng.next_float();
    t = {a, b};
  }
  // A fully empty 4 x 4 block stays empty up its quadtree.
  for (int y = 8; y < 12; ++y)
    for (int x = 8; x < 12; ++x) texels[y * W + x] = {};
  MinMaxPyramid pyr(W, H, texels);
  ASSERT_EQ(pyr.levels(), 7);  // 37 -> 19 -> 10 -> 5 -> 3 -> 2 -> 1
  EXPECT_EQ(pyr.width(1), 19);
  EXPECT_EQ(pyr.height(1), 12);
  EXPECT_EQ(pyr.width(6), 1);
  EXPECT_EQ(pyr.height(6), 1);
  EXPECT_TRUE(pyr.range(2, 2, 2).empty());
  EXPECT_EQ(pyr.level(1).size(), 19u * 12u);
  EXPECT_EQ(pyr.level(1)[3 * 19 + 5].lo, pyr.min(1, 5, 3));
  EXPECT_FALSE(pyr.range(2, 2, 2).overlaps(-kInfinity, kInfinity));
  expect_bounds_everything_below(pyr, texels);
}

TEST(MinMaxPyramid, OneTexelAndOneRow) {
  std::vector<DepthRange> one = {{2, 3}};
  MinMaxPyramid a(1, 1, one);
  EXPECT_EQ(a.levels(), 1);
  EXPECT_EQ(a.root().lo, 2);
  std::vector<DepthRange> row(5);
  for (int i = 0; i < 5; ++i) row[i] = {float(i), float(i) + 0.5f};
  MinMaxPyramid b(5, 1, row);
  EXPECT_EQ(b.levels(), 4);  // 5 -> 3 -> 2 -> 1
  EXPECT_EQ(b.root().lo, 0);
  EXPECT_EQ(b.root().hi, 4.5f);
  expect_bounds_everything_below(b, row);
}

TEST(MinMaxPyramid, OverRasterizedDepthAndLayerMaps) {
  Rng rng(8);
  std::vector<RasterTriangle> tris;
  for (int i = 0; i < 200; ++i) {
    float z = -2 - 8 * rng.next_float();
    Vec3f c{(rng.next_float() - 0.5f) * -z, (rng.next_float() - 0.5f) * -z, z};
    RasterTriangle t;
    for (Vec3f& p : t.p) p = c + Vec3f(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f);
    tris.push_back(t);
  }
  LightView view = LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 50, 100, 70, 1, 20);
  DepthMap depth = render_depth_map(tris, view);
  LayerOptions options;
  options.layers = 4;
  LayeredDepthMap layers = render_layered_depth_map(tris, view, options);
  for (DepthKind kind : {DepthKind::Linear, DepthKind::Window}) {
    std::vector<DepthRange> single(depth.z.size()), multi(depth.z.size());
    for (size_t i = 0; i < single.size(); ++i) {
      float v = kind == DepthKind::Linear ? depth.z[i] : depth.depth[i];
      if (depth.triangle[i] != kNoTriangle) single[i] = {v, v};
      for (int l = 0; l < layers.counts[i]; ++l) {
        const DepthSample& s = layers.samples[i * layers.max_layers + l];
        float w = kind == DepthKind::Linear ? s.z : s.depth;
        multi[i].extend({w, w});  // every layer, not only the first and last
      }
    }
    MinMaxPyramid p1(depth, kind), pk(layers, kind);
    expect_bounds_everything_below(p1, single);
    expect_bounds_everything_below(pk, multi);
    EXPECT_LT(pk.root().lo, pk.root().hi);
    EXPECT_EQ(pk.root().lo, p1.root().lo);  // the first layer is the depth map
    EXPECT_GE(pk.root().hi, p1.root().hi);
    int deeper = 0;  // texels where later layers reach behind the first
    for (int y = 0; y < view.height(); ++y)
      for (int x = 0; x < view.width(); ++x)
        if (pk.max(0, x, y) > p1.max(0, x, y)) ++deeper;
    EXPECT_GT(deeper, 500);
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
