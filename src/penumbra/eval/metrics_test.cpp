#include "penumbra/eval/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "penumbra/core/error.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

Image make(int w, int h, int c, std::initializer_list<float> values) {
  Image im(w, h, c);
  size_t i = 0;
  for (float v : values) im.data()[i++] = v;
  EXPECT_EQ(i, im.data().size());
  return im;
}

// 2x2, one channel. Errors test - ref = {+0.1, 0, -0.2, +0.3}:
//   MAE  = (0.1 + 0 + 0.2 + 0.3) / 4                = 0.15
//   MSE  = (0.01 + 0 + 0.04 + 0.09) / 4             = 0.035,  RMSE = sqrt(0.035) = 0.1870829
//   max  = 0.3;  mean signed = (0.1 - 0.2 + 0.3) / 4 = 0.05
//   PSNR = 10 log10(1 / 0.035)                      = 14.559320 dB (peak 1)
TEST(Metrics, HandComputed2x2) {
  Image ref = make(2, 2, 1, {0.0f, 0.5f, 1.0f, 0.25f});
  Image test = make(2, 2, 1, {0.1f, 0.5f, 0.8f, 0.55f});
  ErrorStats s = compare_images(test, ref);
  EXPECT_EQ(s.pixels, 4u);
  EXPECT_EQ(s.values, 4u);
  EXPECT_NEAR(s.mae, 0.15, 1e-6);
  EXPECT_NEAR(s.rmse, 0.1870829, 1e-6);
  EXPECT_NEAR(s.max_abs, 0.3, 1e-6);
  EXPECT_NEAR(s.mean_signed, 0.05, 1e-6);
  EXPECT_NEAR(s.psnr, 14.559320, 1e-4);
  EXPECT_EQ(s.peak, 1.0);
  // The single-number helpers agree with the one-pass result.
  EXPECT_DOUBLE_EQ(mean_absolute_error(test, ref), s.mae);
  EXPECT_DOUBLE_EQ(rmse(test, ref), s.rmse);
  EXPECT_DOUBLE_EQ(max_absolute_error(test, ref), s.max_abs);
  EXPECT_DOUBLE_EQ(psnr(test, ref), s.psnr);
  EXPECT_DOUBLE_EQ(mean_signed_error(test, ref), s.mean_signed);
  // Swapping the images flips the sign of the signed error only.
  EXPECT_NEAR(mean_signed_error(ref, test), -0.05, 1e-6);
  EXPECT_NEAR(mean_absolute_error(ref, test), 0.15, 1e-6);
}

TEST(Metrics, FractionAboveThreshold) {
  Image ref = make(2, 2, 1, {0.0f, 0.5f, 1.0f, 0.25f});
  Image test = make(2, 2, 1, {0.1f, 0.5f, 0.8f, 0.55f});
  EXPECT_DOUBLE_EQ(fraction_above(test, ref, 0.15), 0.5);   // 0.2 and 0.3 exceed
  EXPECT_DOUBLE_EQ(fraction_above(test, ref, 0.0), 0.75);   // all but the exact pixel
  EXPECT_DOUBLE_EQ(fraction_above(test, ref, 0.5), 0.0);
  EXPECT_DOUBLE_EQ(fraction_above(ref, ref, 0.0), 0.0);     // exact: nothing exceeds 0
}

// 3x1 RGB. Errors per channel: pixel 0 (+0.3, 0, 0), pixel 1 (0, 0, 0), pixel 2 (0, 0, +0.3).
//   all channels: MAE = 0.6 / 9 = 0.0666667, MSE = 0.18 / 9 = 0.02, PSNR = 10 log10 50 = 16.9897
//   channel 2:    MAE = 0.3 / 3 = 0.1,       MSE = 0.09 / 3 = 0.03
//   luminance:    errors 0.2126 * 0.3 = 0.06378, 0, 0.0722 * 0.3 = 0.02166, MAE = 0.02848
TEST(Metrics, ChannelSelection3x1) {
  Image ref = make(3, 1, 3, {0, 0, 0, 1, 1, 1, 0.5f, 0.2f, 0.1f});
  Image test = make(3, 1, 3, {0.3f, 0, 0, 1, 1, 1, 0.5f, 0.2f, 0.4f});
  ErrorStats all = compare_images(test, ref);
  EXPECT_EQ(all.values, 9u);
  EXPECT_NEAR(all.mae, 0.6 / 9, 1e-6);
  EXPECT_NEAR(all.rmse, std::sqrt(0.02), 1e-6);
  EXPECT_NEAR(all.psnr, 16.989700, 1e-4);
  EXPECT_NEAR(all.max_abs, 0.3, 1e-6);

  MetricOptions c2;
  c2.channel = ChannelSelect::channel(2);
  ErrorStats b = compare_images(test, ref, c2);
  EXPECT_EQ(b.values, 3u);
  EXPECT_NEAR(b.mae, 0.1, 1e-6);
  EXPECT_NEAR(b.rmse, std::sqrt(0.03), 1e-6);

  MetricOptions lum;
  lum.channel = ChannelSelect::luminance();
  EXPECT_NEAR(mean_absolute_error(test, ref, lum), (0.06378 + 0.02166) / 3, 1e-6);
  EXPECT_NEAR(max_absolute_error(test, ref, lum), 0.06378, 1e-6);

  // A pixel counts once, when its largest channel error exceeds the threshold.
  EXPECT_NEAR(fraction_above(test, ref, 0.1), 2.0 / 3.0, 1e-12);
  MetricOptions c1;
  c1.channel = ChannelSelect::channel(1);
  EXPECT_DOUBLE_EQ(fraction_above(test, ref, 0.0, c1), 0.0);
}

TEST(Metrics, MaskSelectsPixels) {
  Image ref = make(2, 2, 1, {0.0f, 0.5f, 1.0f, 0.25f});
  Image test = make(2, 2, 1, {0.1f, 0.5f, 0.8f, 0.55f});
  Image mask = make(2, 2, 1, {1, 0, 1, 0});  // pixels with errors +0.1 and -0.2
  MetricOptions o;
  o.mask = &mask;
  ErrorStats s = compare_images(test, ref, o);
  EXPECT_EQ(s.pixels, 2u);
  EXPECT_NEAR(s.mae, 0.15, 1e-6);
  EXPECT_NEAR(s.mean_signed, -0.05, 1e-6);
  EXPECT_NEAR(s.max_abs, 0.2, 1e-6);
  EXPECT_NEAR(s.rmse, std::sqrt(0.025), 1e-6);

  Image none(2, 2, 1, 0.0f);
  o.mask = &none;
  EXPECT_THROW(compare_images(test, ref, o), Error);
  Image wrong(3, 2, 1, 1.0f);
  o.mask = &wrong;
  EXPECT_THROW(compare_images(test, ref, o), Error);
}

TEST(Metrics, PsnrPeakAndExactImages) {
  Image ref = make(2, 1, 1, {2.0f, 1.0f});
  Image test = make(2, 1, 1, {2.0f, 1.5f});  // MSE = 0.25 / 2 = 0.125
  EXPECT_NEAR(psnr(test, ref), 10 * std::log10(1 / 0.125), 1e-9);
  MetricOptions o;
  o.peak = PeakMode::kReferenceMax;  // peak 2: 10 log10(4 / 0.125) = 15.0515 dB
  ErrorStats s = compare_images(test, ref, o);
  EXPECT_DOUBLE_EQ(s.peak, 2.0);
  EXPECT_NEAR(s.psnr, 15.051500, 1e-5);
  EXPECT_EQ(psnr(ref, ref), std::numeric_limits<double>::infinity());
  EXPECT_EQ(rmse(ref, ref), 0.0);
}

TEST(Metrics, MismatchesThrowNamingBothSizes) {
  Image a(3, 2, 1), b(2, 2, 1);
  try {
    compare_images(a, b);
    FAIL() << "expected a size error";
  } catch (const Error& e) {
    std::string msg = e.what();
    EXPECT_NE(msg.find("3x2"), std::string::npos) << msg;
    EXPECT_NE(msg.find("2x2"), std::string::npos) << msg;
  }
  EXPECT_THROW(rmse(Image(2, 2, 3), Image(2, 2, 1)), Error);  // channel counts differ
  MetricOptions o;
  o.channel = ChannelSelect::channel(3);
  EXPECT_THROW(compare_images(Image(2, 2, 3), Image(2, 2, 3), o), Error);
  EXPECT_THROW(difference_map(a, b), Error);
}

TEST(Metrics, NaNIsNotHidden) {
  Image ref(2, 1, 1, 0.5f);
  Image test(2, 1, 1, 0.5f);
  test.at(1, 0) = std::numeric_limits<float>::quiet_NaN();
  ErrorStats s = compare_images(test, ref);
  EXPECT_TRUE(std::isnan(s.mae));
  EXPECT_TRUE(std::isnan(s.max_abs));
  EXPECT_DOUBLE_EQ(s.fraction_above, 0.5);
}

TEST(Metrics, DifferenceMap) {
  Image ref = make(2, 1, 3, {0, 0, 0, 1, 1, 1});
  Image test = make(2, 1, 3, {0.3f, 0, 0, 1, 0.4f, 1});
  Image d = difference_map(test, ref);  // mean over channels
  ASSERT_EQ(d.channels(), 1);
  EXPECT_NEAR(d.at(0, 0), 0.1f, 1e-6f);
  EXPECT_NEAR(d.at(1, 0), -0.2f, 1e-6f);
  Image g = difference_map(test, ref, ChannelSelect::channel(1));
  EXPECT_NEAR(g.at(1, 0), -0.6f, 1e-6f);
  EXPECT_NEAR(g.at(0, 0), 0.0f, 1e-7f);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
