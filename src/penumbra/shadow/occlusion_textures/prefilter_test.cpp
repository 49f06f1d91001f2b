#include "penumbra/shadow/occlusion_textures/prefilter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "penumbra/core/rng.h"

namespace penumbra::occlusion {
namespace {
namespace PENUMBRA_UNITY_ID {

// A random stack of S slices over a w x h texture: blobs of coverage (so that filtered values
// cover the whole range) plus salt.
struct Stack {
  int w, h, s;
  std::vector<uint32_t> masks;
  CoverageStack view() const { return {w, h, s, masks}; }
  bool covered(int k, int x, int y) const { return (masks[static_cast<size_t>(y) * w + x] >> k) & 1u; }
};

Stack random_stack(int w, int h, int s, uint64_t seed) {
  Stack st{w, h, s, std::vector<uint32_t>(static_cast<size_t>(w) * h, 0)};
  Rng rng(seed);
  for (int k = 0; k < s; ++k) {
    for (int blob = 0; blob < 4; ++blob) {
      float cx = rng.next_float() * w, cy = rng.next_float() * h, r = (0.05f + 0.2f * rng.next_float()) * w;
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          if ((x + 0.5f - cx) * (x + 0.5f - cx) + (y + 0.5f - cy) * (y + 0.5f - cy) < r * r)
            st.masks[static_cast<size_t>(y) * w + x] |= 1u << k;
    }
    for (int i = 0; i < w * h / 20; ++i)
      st.masks[static_cast<size_t>(rng.next_float() * h) * w + static_cast<size_t>(rng.next_float() * w)] ^= 1u << k;
  }
  return st;
}

// The exact mean of slice k over [x0, x1] x [y0, y1] (outside = 0): the overlap of the
// rectangle with every covered texel square.
double brute_box(const Stack& st, int k, double x0, double y0, double x1, double y1) {
  double sum = 0;
  for (int y = std::max(0, int(std::floor(y0))); y < std::min(st.h, int(std::ceil(y1))); ++y)
    for (int x = std::max(0, int(std::floor(x0))); x < std::min(st.w, int(std::ceil(x1))); ++x) {
      if (!st.covered(k, x, y)) continue;
      double ox = std::min<double>(x + 1, x1) - std::max<double>(x, x0);
      double oy = std::min<double>(y + 1, y1) - std::max<double>(y, y0);
      if (ox > 0 && oy > 0) sum += ox * oy;
    }
  return sum / ((x1 - x0) * (y1 - y0));
}

TEST(Prefilter, SummedAreaTablesAreTheExactBoxFilter) {
  const Stack st = random_stack(64, 64, 5, 3);
  SatFilter<uint32_t> sat32;
  SatFilter<double> sat64;
  sat32.build(st.view());
  sat64.build(st.view());
  for (int x = 0; x <= 64; x += 7)
    for (int y = 0; y <= 64; y += 5) {
      int count = 0;
      for (int j = 0; j < y; ++j)
        for (int i = 0; i < x; ++i) count += st.covered(2, i, j);
      EXPECT_EQ(sat32.entry(2, x, y), uint32_t(count));
      EXPECT_EQ(sat64.entry(2, x, y), double(count));
    }
  Rng rng(5);
  LookupCounters n;
  for (int trial = 0; trial < 2000; ++trial) {
    const int k = trial % st.s;
    // Any size from a fraction of a texel to wider than the texture, partly outside too.
    const float size = std::exp(rng.next_float() * 5.0f - 1.5f);
    const float x0 = rng.next_float() * 80 - 8, y0 = rng.next_float() * 80 - 8;
    const float x1 = x0 + size * (0.5f + rng.next_float()), y1 = y0 + size * (0.5f + rng.next_float());
    const double expect = brute_box(st, k, x0, y0, x1, y1);
    EXPECT_NEAR(sat32.box(k, x0, y0, x1, y1, n), expect, 2e-5 + 1e-5 * expect) << x0 << " " << y0 << " " << x1 << " " << y1;
    EXPECT_NEAR(sat64.box(k, x0, y0, x1, y1, n), expect, 2e-5 + 1e-5 * expect);
  }
  EXPECT_EQ(n.lookups, 4000u);
}

TEST(Prefilter, NBufferLevelsAreBoxMeansAndExactAtTheirOwnSize) {
  const Stack st = random_stack(64, 64, 3, 7);
  NBufferFilter nb;
  nb.build(st.view());
  ASSERT_EQ(nb.levels(), 7);  // boxes of 1 .. 64 texels
  for (int l = 0; l < nb.levels(); ++l) {
    const int n = 1 << l;
    EXPECT_EQ(nb.level_width(l), 64 - n + 1);
    // 8-bit means rebuilt level by level: each level adds at most half a step of rounding.
    const double tolerance = (0.5 * l + 0.5) / 255.0;
    for (int y = 0; y < nb.level_height(l); y += 3)
      for (int x = 0; x < nb.level_width(l); x += 3)
        ASSERT_NEAR(nb.texel(l, 1, x, y), brute_box(st, 1, x, y, x + n, y + n), tolerance) << l << " " << x << " " << y;
  }
  // A square of side 2^l anywhere inside (real position): the bilinear blend of its four
  // integer anchors is the exact box mean, up to the 8-bit rounding.
  Rng rng(9);
  LookupCounters n;
  for (int trial = 0; trial < 500; ++trial) {
    const int l = trial % 6;
    const float side = float(1 << l);
    const float cx = side / 2 + rng.next_float() * (64 - side), cy = side / 2 + rng.next_float() * (64 - side);
    const double expect = brute_box(st, 0, cx - side / 2, cy - side / 2, cx + side / 2, cy + side / 2);
    EXPECT_NEAR(nb.box(0, cx - side / 2, cy - side / 2, cx + side / 2, cy + side / 2, n), expect, (0.5 * l + 0.5) / 255.0);
  }
  // In between two sizes it interpolates: never far from the true mean on smooth coverage.
  for (int trial = 0; trial < 500; ++trial) {
    const float side = 1.0f + rng.next_float() * 40;
    const float cx = side / 2 + rng.next_float() * (64 - side), cy = side / 2 + rng.next_float() * (64 - side);
    const double expect = brute_box(st, 2, cx - side / 2, cy - side / 2, cx + side / 2, cy + side / 2);
    EXPECT_NEAR(nb.box(2, cx - side / 2, cy - side / 2, cx + side / 2, cy + side / 2, n), expect, 0.25);
  }
}

TEST(Prefilter, MipmapLevelsAreDyadicBlockMeans) {
  const Stack st = random_stack(64, 64, 2, 11);
  MipmapFilter mip;
  mip.build(st.view());
  ASSERT_EQ(mip.levels(), 7);  // 64 .. 1 texels
  for (int l = 0; l < mip.levels(); ++l) {
    const int n = 1 << l;
    EXPECT_EQ(mip.level_width(l), 64 >> l);
    for (int y = 0; y < mip.level_height(l); ++y)
      for (int x = 0; x < mip.level_width(l); ++x)
        ASSERT_NEAR(mip.texel(l, 1, x, y), brute_box(st, 1, x * n, y * n, (x + 1) * n, (y + 1) * n), (0.5 * l + 0.5) / 255.0);
  }
  // At a texel-aligned square of a level's own size, trilinear reads that level's texel.
  LookupCounters n;
  EXPECT_NEAR(mip.box(1, 16, 32, 32, 48, n), mip.texel(4, 1, 1, 2), 0.01);
  EXPECT_EQ(n.reads, 8u);
}

TEST(Prefilter, BatchesEqualSingleLookups) {
  // squares() (the shading path) against box() one square at a time: squares inside, cut by
  // the border into near-squares and into strips, and entirely outside.
  const Stack st = random_stack(128, 128, 4, 13);
  MipmapFilter mip;
  NBufferFilter nb;
  SatFilter<uint32_t> sat;
  mip.build(st.view());
  nb.build(st.view());
  sat.build(st.view());
  Rng rng(17);
  std::vector<float> cx, cy, side;
  for (int i = 0; i < 300; ++i) {
    side.push_back(std::exp(rng.next_float() * 5.5f - 1.0f));
    cx.push_back(rng.next_float() * 180 - 26);
    cy.push_back(rng.next_float() * 180 - 26);
  }
  auto check = [&](const auto& f, const char* name) {
    for (int k = 0; k < st.s; ++k) {
      std::vector<float> out(cx.size());
      LookupCounters batch, single;
      f.squares(k, cx.size(), cx.data(), cy.data(), side.data(), out.data(), batch);
      for (size_t i = 0; i < cx.size(); ++i) {
        const float h = 0.5f * std::max(side[i], 1.0f);
        const float one = f.box(k, cx[i] - h, cy[i] - h, cx[i] + h, cy[i] + h, single);
        EXPECT_NEAR(out[i], one, 1e-5f) << name << " k=" << k << " i=" << i << " side=" << side[i];
      }
      EXPECT_EQ(batch.lookups, cx.size()) << name;
    }
  };
  check(mip, "mipmap");
  check(nb, "nbuffer");
  check(sat, "sat");
}

TEST(Prefilter, CoverageBoundsAreTheCoveredTexels) {
  Stack st{32, 16, 3, std::vector<uint32_t>(32 * 16, 0)};
  st.masks[3 * 32 + 5] = 1;
  st.masks[9 * 32 + 20] = 1 | 4;
  std::vector<SliceBounds> b = coverage_bounds(st.view());
  EXPECT_EQ(b[0].x0, 5);
  EXPECT_EQ(b[0].x1, 21);
  EXPECT_EQ(b[0].y0, 3);
  EXPECT_EQ(b[0].y1, 10);
  EXPECT_FALSE(b[1].meets(0, 0, 32, 16));  // slice 1 covers nothing
  EXPECT_TRUE(b[2].meets(19.5f, 8.5f, 20.5f, 9.5f));
  EXPECT_FALSE(b[2].meets(21.0f, 0, 30, 16));
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::occlusion
