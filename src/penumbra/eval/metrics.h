// Pixel-wise error metrics between a test image and a reference image of equal size:
// mean absolute error, RMSE, maximum absolute error, PSNR, mean signed error and the
// fraction of pixels whose error exceeds a threshold. docs/metrics.md states the
// conventions; in short:
//  - error = test - reference (a positive mean signed error means "test too bright");
//  - values are compared as stored (linear, unclamped): no tone mapping, no clamping;
//  - a metric runs over every channel of every selected pixel, over the Rec. 709
//    luminance of each pixel, or over one channel (ChannelSelect);
//  - PSNR = 10 log10(peak^2 / MSE) with peak 1 by default (V images live in [0,1], and
//    LDR colour images are 1 at white), or the reference's maximum (PeakMode);
//  - an optional mask (one channel, same size) selects the pixels: value >= 0.5.
// Sums are accumulated in double, per row, and added in row order, so the results do not
// depend on the thread count.
#pragma once

#include <cstddef>
#include <string>

#include "penumbra/core/image.h"

namespace penumbra {

// Which values of a pixel a metric compares.
struct ChannelSelect {
  enum class Kind { kAll, kLuminance, kIndex };
  Kind kind = Kind::kAll;
  int index = 0;  // for kIndex

  // Every channel of every pixel: an RGB image contributes 3 values a pixel.
  static ChannelSelect all() { return {Kind::kAll, 0}; }
  // Rec. 709 luminance of RGB pixels (core/math.h luminance()); for single-channel
  // images it is that channel.
  static ChannelSelect luminance() { return {Kind::kLuminance, 0}; }
  static ChannelSelect channel(int c) { return {Kind::kIndex, c}; }
  std::string name() const;  // "all", "luminance", "channel 2"
};

enum class PeakMode {
  kOne,           // peak = 1 (default; V images, LDR colour images)
  kReferenceMax,  // peak = the largest selected reference value (HDR radiance images)
};

struct MetricOptions {
  ChannelSelect channel = ChannelSelect::all();
  // One channel, the size of the images; a pixel is included where mask >= 0.5. Null:
  // every pixel. Not owned.
  const Image* mask = nullptr;
  PeakMode peak = PeakMode::kOne;
  // fraction_above counts pixels whose |error| exceeds this (strictly).
  double threshold = 0.0;
};

struct ErrorStats {
  size_t pixels = 0;  // selected pixels
  size_t values = 0;  // compared values (pixels x channels)
  double mae = 0;             // mean |test - ref|
  double rmse = 0;            // sqrt(mean (test - ref)^2)
  double max_abs = 0;         // max |test - ref|
  double mean_signed = 0;     // mean (test - ref)
  double peak = 1;            // the PSNR peak actually used
  double psnr = 0;            // 10 log10(peak^2 / MSE) in dB; +infinity when MSE = 0,
                              // NaN when the peak is not positive
  double fraction_above = 0;  // fraction of selected pixels with |error| > threshold
};

// All metrics in one pass. Throws Error when the sizes or channel counts differ (naming
// both), when the channel does not exist, when the mask is not a one-channel image of
// the same size, or when the mask selects no pixel.
ErrorStats compare_images(const Image& test, const Image& reference,
                          const MetricOptions& options = {});

// Single metrics, for callers that want one number (each is one compare_images pass).
double mean_absolute_error(const Image& test, const Image& reference,
                           const MetricOptions& options = {});
double rmse(const Image& test, const Image& reference, const MetricOptions& options = {});
double max_absolute_error(const Image& test, const Image& reference,
                          const MetricOptions& options = {});
double psnr(const Image& test, const Image& reference, const MetricOptions& options = {});
double mean_signed_error(const Image& test, const Image& reference,
                         const MetricOptions& options = {});
// Fraction in [0,1] of selected pixels where |test - reference| > threshold. With several
// channels a pixel counts when any selected channel exceeds it (the per-pixel error is
// the largest channel error), so "fraction_above(a, b, 0) == 0" means "bit-exact up to
// the threshold in every channel". Used by exactness tests.
double fraction_above(const Image& test, const Image& reference, double threshold,
                      const MetricOptions& options = {});

// Per-pixel signed error test - reference as a one-channel image, for heat maps. For
// ChannelSelect::all() on a multi-channel image it is the mean over the channels.
Image difference_map(const Image& test, const Image& reference,
                     ChannelSelect channel = ChannelSelect::all());

}  // namespace penumbra
