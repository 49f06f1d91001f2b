#include "penumbra/eval/flip.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/core/rng.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

Image constant(int w, int h, Vec3f c) {
  Image im(w, h, 3);
  for (size_t i = 0; i < im.pixel_count(); ++i) im.set_rgb(i, c);
  return im;
}

// A deterministic textured image: smooth gradients plus per-pixel noise, in [0,1].
Image textured(int w, int h, uint64_t seed) {
  Image im(w, h, 3);
  Rng rng(seed);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float u = float(x) / w, v = float(y) / h;
      im.at(x, y, 0) = clamp01(0.6f * u + 0.4f * rng.next_float());
      im.at(x, y, 1) = clamp01(0.5f * v + 0.5f * rng.next_float());
      im.at(x, y, 2) = clamp01(0.3f + 0.3f * std::sin(9 * u + 5 * v) + 0.2f * rng.next_float());
    }
  return im;
}

TEST(Flip, DefaultPixelsPerDegree) {
  // 0.7 m * (3840 px / 0.7 m) * pi / 180 = 3840 pi / 180 = 67.0206 pixels per degree.
  EXPECT_NEAR(flip_default_ppd(), 67.0206f, 1e-3f);
  EXPECT_NEAR(flip_pixels_per_degree(1.4f, 0.7f, 3840), 2 * 67.0206f, 2e-3f);
}

TEST(Flip, IdenticalImagesGiveZero) {
  Image a = textured(40, 24, 7);
  FlipResult r = flip(a, a);
  ASSERT_EQ(r.error.width(), 40);
  ASSERT_EQ(r.error.channels(), 1);
  for (float e : r.error.data()) ASSERT_EQ(e, 0.0f);
  EXPECT_EQ(r.mean, 0.0);
}

// Black vs white, by hand from Andersson et al. 2020:
//  1. Both images are constant: the CSF kernels sum to 1 and borders are clamped, so the
//     filtered images equal the inputs; every feature filter response is 0, so dE_f = 0.
//  2. L*a*b* (D65 white): black Y/Yn = 0 -> f = 4/29, L* = 116 * 4/29 - 16 = 0; white
//     Y/Yn = 1 -> L* = 100; a* = b* = 0 for both (grey). Hunt: 0.01 L* a* = 0, same for b.
//  3. HyAB = |100 - 0| + sqrt(0 + 0) = 100;  100^qc = 100^0.7 = 10^1.4 = 25.11886.
//  4. cmax: green (0,1,0) -> XYZ (0.3575761, 0.7151522, 0.1191920) -> L*a*b*
//     (87.73472, -86.18270, 83.17931) -> Hunt (87.73472, -75.61215, 72.97714);
//     blue (0,0,1) -> XYZ (0.1804375, 0.0721750, 0.9503041) -> L*a*b*
//     (32.29701, 79.18753, -107.86016) -> Hunt (32.29701, 25.57520, -34.83561).
//     HyAB = 55.43771 + sqrt(101.18735^2 + 107.81275^2) = 55.43771 + 147.85962 = 203.29733;
//     cmax = 203.29733^0.7 = 41.27548;  pc * cmax = 0.4 * 41.27548 = 16.51019.
//  5. 25.11886 >= 16.51019: upper segment,
//     dE_c = pt + (25.11886 - 16.51019) / (41.27548 - 16.51019) * (1 - pt)
//          = 0.95 + 8.60867 / 24.76529 * 0.05 = 0.95 + 0.0173805 = 0.9673805.
//  6. FLIP = dE_c^(1 - dE_f) = 0.9673805^1 = 0.9673805 at every pixel.
TEST(Flip, BlackVersusWhiteByHand) {
  Image black = constant(16, 12, Vec3f(0.0f)), white = constant(16, 12, Vec3f(1.0f));
  FlipResult r = flip(white, black, {.ppd = flip_default_ppd(), .keep_components = true});
  for (size_t i = 0; i < r.error.pixel_count(); ++i) {
    ASSERT_NEAR(r.error.data()[i], 0.9673805f, 5e-6f) << "pixel " << i;
    ASSERT_EQ(r.feature.data()[i], 0.0f);
  }
  EXPECT_NEAR(r.mean, 0.9673805, 5e-6);
}

// Uniform grey pair, linear 0.5 (reference) vs 0.25 (test), by hand:
//  1. Constant images: the filters are the identity, dE_f = 0 (see BlackVersusWhiteByHand).
//  2. Grey is achromatic: a* = b* = 0, so Hunt adjustment and the chroma term vanish.
//     L*(0.5)  = 116 * 0.5^(1/3)  - 16 = 116 * 0.7937005 - 16 = 76.06926
//     L*(0.25) = 116 * 0.25^(1/3) - 16 = 116 * 0.6299605 - 16 = 57.07542
//  3. HyAB = |76.06926 - 57.07542| = 18.99384;  18.99384^0.7 = 7.852880.
//  4. 7.852880 < pc * cmax = 16.51019: lower segment,
//     dE_c = pt / (pc * cmax) * 7.852880 = 0.95 / 16.51019 * 7.852880 = 0.4518563.
//  5. FLIP = 0.4518563^(1 - 0) = 0.4518563.
TEST(Flip, UniformGreyPairByHand) {
  Image ref = constant(9, 7, Vec3f(0.5f)), test = constant(9, 7, Vec3f(0.25f));
  FlipResult r = flip(test, ref);
  for (float e : r.error.data()) ASSERT_NEAR(e, 0.4518563f, 5e-6f);
  EXPECT_NEAR(r.mean, 0.4518563, 5e-6);
  // A one-channel image is grey: the same result.
  Image ref1(9, 7, 1, 0.5f), test1(9, 7, 1, 0.25f);
  EXPECT_NEAR(flip(test1, ref1).mean, r.mean, 1e-6);
}

TEST(Flip, ValuesInUnitIntervalAndSymmetric) {
  Image a = textured(48, 40, 1), b = textured(48, 40, 2);
  // Out-of-range inputs are clamped (LDR-FLIP), so HDR values cannot push FLIP above 1.
  a.at(3, 3, 0) = 7.0f;
  b.at(5, 9, 2) = -2.0f;
  FlipResult ab = flip(a, b), ba = flip(b, a);
  for (size_t i = 0; i < ab.error.pixel_count(); ++i) {
    float e = ab.error.data()[i];
    ASSERT_GE(e, 0.0f);
    ASSERT_LE(e, 1.0f);
    // Every step is symmetric in its two images (|L1 - L2|, squared chroma differences,
    // |edge_1 - edge_2|), and each image is processed alone: exactly equal.
    ASSERT_EQ(e, ba.error.data()[i]) << "pixel " << i;
  }
  EXPECT_GT(ab.mean, 0.05);
}

TEST(Flip, MirroringBothImagesMirrorsTheMap) {
  // Kernels are symmetric (or antisymmetric, used through magnitudes) and borders clamp
  // symmetrically, so FLIP commutes with a horizontal mirror up to float rounding.
  Image a = textured(33, 20, 3), b = textured(33, 20, 4);
  auto mirror = [](const Image& im) {
    Image m(im.width(), im.height(), im.channels());
    for (int y = 0; y < im.height(); ++y)
      for (int x = 0; x < im.width(); ++x)
        for (int c = 0; c < im.channels(); ++c) m.at(im.width() - 1 - x, y, c) = im.at(x, y, c);
    return m;
  };
  FlipResult r = flip(a, b), rm = flip(mirror(a), mirror(b));
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 33; ++x) ASSERT_NEAR(r.error.at(x, y), rm.error.at(32 - x, y), 1e-4f);
}

TEST(Flip, LargerDifferenceOnFlatPatchGivesLargerError) {
  Image ref = constant(48, 48, Vec3f(0.4f, 0.4f, 0.4f));
  float prev_centre = 0, prev_mean = 0;
  for (float d : {0.01f, 0.03f, 0.08f, 0.15f, 0.3f, 0.6f}) {
    Image test = ref;
    for (int y = 16; y < 32; ++y)
      for (int x = 16; x < 32; ++x) test.set_rgb(size_t(y) * 48 + x, Vec3f(0.4f + d, 0.4f, 0.4f - d / 2));
    FlipResult r = flip(test, ref);
    float centre = r.error.at(24, 24);
    EXPECT_GT(centre, prev_centre) << "d = " << d;
    EXPECT_GT(r.mean, prev_mean) << "d = " << d;
    // Far from the patch (beyond the filter supports) there is no difference.
    EXPECT_EQ(r.error.at(1, 1), 0.0f);
    prev_centre = centre;
    prev_mean = float(r.mean);
  }
}

TEST(Flip, FeaturePipelineRaisesFireflyError) {
  // A single bright pixel (a firefly) on a grey field: the point detector sees it, so the
  // final error exceeds the colour-only error there (dE_c^(1 - dE_f) > dE_c for dE_f > 0).
  Image ref = constant(31, 31, Vec3f(0.2f)), test = ref;
  test.set_rgb(15 * 31 + 15, Vec3f(1.0f));
  FlipResult r = flip(test, ref, {.ppd = flip_default_ppd(), .keep_components = true});
  float e = r.error.at(15, 15), c = r.color.at(15, 15), f = r.feature.at(15, 15);
  EXPECT_GT(f, 0.1f);
  EXPECT_GT(e, c);
  EXPECT_NEAR(e, std::pow(c, 1.0f - f), 1e-5f);
  // The CSF blurs a one-pixel firefly: its colour error is far below a uniform white-vs-grey.
  Image white = constant(31, 31, Vec3f(1.0f));
  EXPECT_LT(c, flip(white, ref).error.at(15, 15));
}

TEST(Flip, SizeMismatchAndBadParametersThrow) {
  try {
    flip(Image(4, 3, 3), Image(3, 4, 3));
    FAIL() << "expected a size error";
  } catch (const Error& e) {
    std::string msg = e.what();
    EXPECT_NE(msg.find("4x3"), std::string::npos) << msg;
    EXPECT_NE(msg.find("3x4"), std::string::npos) << msg;
  }
  EXPECT_THROW(flip(Image(4, 4, 3), Image(4, 4, 3), {.ppd = 0.0f}), Error);
  EXPECT_THROW(flip(Image(4, 4, 2), Image(4, 4, 3)), Error);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
