#include "penumbra/core/sampling.h"

#include "penumbra/core/error.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

TEST(Stratification, GridIsAsSquareAsPossible) {
  int c, r;
  stratification_grid(256, &c, &r);
  EXPECT_EQ(c, 16); EXPECT_EQ(r, 16);
  stratification_grid(128, &c, &r);
  EXPECT_EQ(c * r, 128); EXPECT_EQ(r, 8);
  stratification_grid(7, &c, &r);
  EXPECT_EQ(c, 7); EXPECT_EQ(r, 1);
  EXPECT_THROW(stratification_grid(0, &c, &r), Error);
}

TEST(Stratification, OneSamplePerCell) {
  Rng rng(42);
  auto s = stratified_samples(64, rng);
  ASSERT_EQ(s.size(), 64u);
  std::set<int> cells;
  for (auto p : s) {
    ASSERT_GE(p.x, 0.0f); ASSERT_LT(p.x, 1.0f);
    ASSERT_GE(p.y, 0.0f); ASSERT_LT(p.y, 1.0f);
    cells.insert(static_cast<int>(p.x * 8) + 8 * static_cast<int>(p.y * 8));
  }
  EXPECT_EQ(cells.size(), 64u);
}

TEST(LightSampleSet, PerPixelRotationKeepsStrataAndDiffersAcrossPixels) {
  LightSampleSet fixed(16, 7, false), rotated(16, 7, true);
  EXPECT_EQ(fixed.sample(3, 0).x, fixed.sample(3, 99).x);  // fixed: same for every pixel
  EXPECT_NE(rotated.sample(3, 0).x, rotated.sample(3, 99).x);
  // A toroidal shift maps the 4x4 strata onto a shifted 4x4 pattern: the sample mean of
  // the rotated set stays near 0.5 (stratification preserved).
  double mx = 0;
  for (int i = 0; i < 16; ++i) mx += rotated.sample(i, 1234).x;
  EXPECT_NEAR(mx / 16, 0.5, 0.08);
}

TEST(Rng, CounterBasedAndReproducible) {
  Rng a(1, 2, 3), b(1, 2, 3), c(1, 2, 4);
  for (int i = 0; i < 10; ++i) {
    float x = a.next_float();
    EXPECT_EQ(x, b.next_float());
    EXPECT_NE(x, c.next_float());
  }
}

TEST(Sampling, ConcentricDiskStaysInsideAndCoversArea) {
  Rng rng(5);
  int inside_half = 0, n = 20000;
  for (int i = 0; i < n; ++i) {
    Vec2f d = square_to_disk_concentric(rng.next_2d());
    float r2 = d.x * d.x + d.y * d.y;
    ASSERT_LE(r2, 1.0f + 1e-5f);
    if (r2 < 0.25f) ++inside_half;
  }
  // Uniform on the disk: P(r < 1/2) = 1/4.
  EXPECT_NEAR(static_cast<double>(inside_half) / n, 0.25, 0.01);
}

// concentric_square inverts concentric_disk: back to the same point of the square (to float
// rounding), in each of the four wedges and on their diagonals, and the centre to the centre.
TEST(Sampling, ConcentricSquareInvertsTheConcentricDisk) {
  Rng rng(11);
  float worst = 0;
  for (int i = 0; i < 20000; ++i) {
    Vec2f u = rng.next_2d();
    if (i < 4) u = Vec2f(i & 1 ? 0.9f : 0.1f, i & 2 ? 0.9f : 0.1f);  // the wedges' diagonals
    const Vec2f back = shader::concentric_square(shader::concentric_disk(u));
    worst = std::max({worst, std::abs(back.x - u.x), std::abs(back.y - u.y)});
  }
  EXPECT_LT(worst, 1e-5f);
  const Vec2f centre = shader::concentric_square(Vec2f(0.0f, 0.0f));
  EXPECT_EQ(centre.x, 0.5f);
  EXPECT_EQ(centre.y, 0.5f);
}

// Issue 20 part 3: a piecewise-constant density on a 4 x 2 grid. Samples land in each cell in
// proportion to its value (empty cells never), the pdf is the normalised value (mean 1), and a
// stratified input stays stratified (each column of the input lands in one cell run).
TEST(PiecewiseConstant2D, SamplesFollowTheValuesAndThePdfIsNormalised) {
  const std::vector<float> values = {1, 0, 3, 4,   // row 0: v in [0, 0.5)
                                     2, 2, 0, 8};  // row 1
  const PiecewiseConstant2D d(values, 4, 2);
  EXPECT_FLOAT_EQ(d.mean(), 20.0f / 8);
  std::vector<int> hits(8, 0);
  Rng rng(7, 1);
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const Vec2f p = d.sample(rng.next_2d());
    ASSERT_TRUE(p.x >= 0 && p.x <= 1 && p.y >= 0 && p.y <= 1);
    const int cx = std::min(3, static_cast<int>(p.x * 4)), cy = std::min(1, static_cast<int>(p.y * 2));
    ++hits[cy * 4 + cx];
  }
  double integral = 0;
  for (int k = 0; k < 8; ++k) {
    EXPECT_NEAR(static_cast<double>(hits[k]) / n, values[k] / 20.0, 0.004) << k;
    const Vec2f centre{(k % 4 + 0.5f) / 4, (k / 4 + 0.5f) / 2};
    EXPECT_FLOAT_EQ(d.pdf(centre), values[k] / 2.5f);
    integral += d.pdf(centre) / 8;
  }
  EXPECT_NEAR(integral, 1.0, 1e-6);
  EXPECT_EQ(hits[1], 0);
  EXPECT_EQ(hits[6], 0);
  // Monotonic in u.x within a row: a warp, not a shuffle.
  float last = -1;
  for (int i = 0; i < 100; ++i) {
    const Vec2f p = d.sample({(i + 0.5f) / 100, 0.9f});
    EXPECT_GE(p.x, last);
    last = p.x;
  }
  // All zero: uniform.
  const PiecewiseConstant2D zero(std::vector<float>(8, 0.0f), 4, 2);
  const Vec2f q = zero.sample({0.3f, 0.7f});
  EXPECT_NEAR(q.x, 0.3f, 1e-6f);
  EXPECT_NEAR(q.y, 0.7f, 1e-6f);
  EXPECT_THROW(PiecewiseConstant2D({1, -1}, 2, 1), Error);
  EXPECT_THROW(PiecewiseConstant2D({1, 1, 1}, 2, 1), Error);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
