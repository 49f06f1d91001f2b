#include "penumbra/eval/heatmap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "penumbra/core/error.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

Vec3f linear_pixel(const Image& im, int x) {
  return im.rgb(size_t(x));
}

void expect_srgb(Vec3f linear, Vec3f srgb, float tol = 2e-3f) {
  EXPECT_NEAR(linear_to_srgb(linear.x), srgb.x, tol);
  EXPECT_NEAR(linear_to_srgb(linear.y), srgb.y, tol);
  EXPECT_NEAR(linear_to_srgb(linear.z), srgb.z, tol);
}

TEST(Heatmap, ColorMapEndsAndCentre) {
  Vec3f m0 = colormap_srgb(ColorMap::kMagma, 0), m1 = colormap_srgb(ColorMap::kMagma, 1);
  EXPECT_NEAR(m0.x, 0.001462f, 1e-6f);
  EXPECT_NEAR(m0.z, 0.013866f, 1e-6f);
  EXPECT_NEAR(m1.y, 0.991438f, 1e-6f);
  // magma(128/255) is a table entry.
  Vec3f mid = colormap_srgb(ColorMap::kMagma, 128.0f / 255.0f);
  EXPECT_NEAR(mid.x, 0.716387f, 1e-5f);
  EXPECT_NEAR(mid.y, 0.214982f, 1e-5f);
  // Out of range clamps to the ends.
  EXPECT_EQ(colormap_srgb(ColorMap::kMagma, -3.0f), m0);
  EXPECT_EQ(colormap_srgb(ColorMap::kMagma, 9.0f), m1);
  EXPECT_EQ(colormap_srgb(ColorMap::kDiverging, 0.5f), Vec3f(1.0f));
  Vec3f blue = colormap_srgb(ColorMap::kDiverging, 0), red = colormap_srgb(ColorMap::kDiverging, 1);
  EXPECT_GT(blue.z, blue.x);
  EXPECT_GT(red.x, red.z);
}

TEST(Heatmap, MagmaLightnessIncreases) {
  // A sequential map for error magnitudes must get brighter with the error (magma is
  // monotonic in lightness); a typo in the table would break this.
  float prev = -1;
  for (int i = 0; i <= 64; ++i) {
    Vec3f c = colormap_srgb(ColorMap::kMagma, i / 64.0f);
    float y = luminance(Vec3f(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z)));
    EXPECT_GT(y, prev) << "t = " << i / 64.0f;
    prev = y;
  }
}

TEST(Heatmap, AbsoluteScaleAndColours) {
  Image err(4, 1, 1);
  err.data() = {0.0f, 0.25f, 0.5f, -0.5f};
  Heatmap hm = absolute_heatmap(err);  // auto scale: max |e| = 0.5
  EXPECT_EQ(hm.lo, 0.0f);
  EXPECT_EQ(hm.hi, 0.5f);
  ASSERT_EQ(hm.image.channels(), 3);
  expect_srgb(linear_pixel(hm.image, 0), colormap_srgb(ColorMap::kMagma, 0));
  expect_srgb(linear_pixel(hm.image, 1), colormap_srgb(ColorMap::kMagma, 0.5f));
  expect_srgb(linear_pixel(hm.image, 2), colormap_srgb(ColorMap::kMagma, 1));
  EXPECT_EQ(linear_pixel(hm.image, 3), linear_pixel(hm.image, 2));  // |-0.5| = 0.5
  EXPECT_EQ(hm.legend(), "magma: 0 (black) .. 0.5 (light yellow)");

  Heatmap fixed = absolute_heatmap(err, 1.0f);  // explicit scale: 0.5 is mid-map
  EXPECT_EQ(fixed.hi, 1.0f);
  expect_srgb(linear_pixel(fixed.image, 2), colormap_srgb(ColorMap::kMagma, 0.5f));

  Image zero(2, 1, 1, 0.0f);
  EXPECT_EQ(absolute_heatmap(zero).hi, 1.0f);
}

TEST(Heatmap, SignedIsSymmetricWithWhiteZero) {
  Image err(5, 1, 1);
  err.data() = {0.0f, 0.1f, -0.1f, 0.05f, 3.0f};
  Heatmap hm = signed_heatmap(err, 0.1f);
  EXPECT_EQ(hm.lo, -0.1f);
  EXPECT_EQ(hm.hi, 0.1f);
  expect_srgb(linear_pixel(hm.image, 0), Vec3f(1.0f), 1e-5f);
  expect_srgb(linear_pixel(hm.image, 1), colormap_srgb(ColorMap::kDiverging, 1));
  expect_srgb(linear_pixel(hm.image, 2), colormap_srgb(ColorMap::kDiverging, 0));
  expect_srgb(linear_pixel(hm.image, 3), colormap_srgb(ColorMap::kDiverging, 0.75f));
  EXPECT_EQ(linear_pixel(hm.image, 4), linear_pixel(hm.image, 1));  // clamped
  EXPECT_EQ(hm.legend(), "diverging: -0.1 (blue) .. 0 (white) .. 0.1 (red)");
  EXPECT_EQ(signed_heatmap(err).hi, 3.0f);  // auto: max |e|
  EXPECT_EQ(signed_heatmap(err).lo, -3.0f);
}

TEST(Heatmap, NaNIsGreenAndMultiChannelThrows) {
  Image err(2, 1, 1, 0.2f);
  err.data()[1] = std::numeric_limits<float>::quiet_NaN();
  Heatmap hm = absolute_heatmap(err);
  EXPECT_EQ(hm.hi, 0.2f);  // NaN ignored by the auto scale
  EXPECT_EQ(linear_pixel(hm.image, 1), Vec3f(0.0f, 1.0f, 0.0f));
  EXPECT_THROW(absolute_heatmap(Image(2, 2, 3)), Error);
  EXPECT_THROW(signed_heatmap(Image(2, 2, 3)), Error);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
