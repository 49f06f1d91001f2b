#include "penumbra/core/sampling.h"

#include "penumbra/core/error.h"

#include <gtest/gtest.h>

#include <set>

namespace penumbra {
namespace {

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

}  // namespace
}  // namespace penumbra
