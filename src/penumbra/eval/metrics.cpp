#include "penumbra/eval/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra {

std::string ChannelSelect::name() const {
  switch (kind) {
    case Kind::kAll: return "all";
    case Kind::kLuminance: return "luminance";
    case Kind::kIndex: return fmt::format("channel {}", index);
  }
  return "?";
}

namespace {

std::string describe(const Image& im) {
  return fmt::format("{}x{} ({} channel{})", im.width(), im.height(), im.channels(),
                     im.channels() == 1 ? "" : "s");
}

void check_pair(const Image& test, const Image& reference, ChannelSelect channel) {
  if (test.width() != reference.width() || test.height() != reference.height() ||
      test.channels() != reference.channels())
    throw Error("image sizes differ: test is {}, reference is {}", describe(test),
                describe(reference));
  if (test.empty()) throw Error("cannot compare empty images");
  if (channel.kind == ChannelSelect::Kind::kIndex &&
      (channel.index < 0 || channel.index >= test.channels()))
    throw Error("channel {} does not exist: the images have {} channel(s)", channel.index,
                test.channels());
}

void check_mask(const Image* mask, const Image& test) {
  if (!mask) return;
  if (mask->channels() != 1 || mask->width() != test.width() || mask->height() != test.height())
    throw Error("mask must be one channel of {}x{}, got {}", test.width(), test.height(),
                describe(*mask));
}

// The values of pixel i that a metric compares; returns how many (1 or channels).
int select_values(const Image& im, size_t i, ChannelSelect channel, float* out) {
  const float* p = im.pixel(i);
  switch (channel.kind) {
    case ChannelSelect::Kind::kAll:
      for (int c = 0; c < im.channels(); ++c) out[c] = p[c];
      return im.channels();
    case ChannelSelect::Kind::kLuminance:
      out[0] = im.channels() >= 3 ? luminance(Vec3f(p[0], p[1], p[2])) : p[0];
      return 1;
    case ChannelSelect::Kind::kIndex:
      out[0] = p[channel.index];
      return 1;
  }
  return 0;
}

struct Partial {
  double sum_abs = 0, sum_sq = 0, sum_signed = 0, max_abs = 0;
  double ref_max = -std::numeric_limits<double>::infinity();
  size_t pixels = 0, values = 0, above = 0;
};

}  // namespace

ErrorStats compare_images(const Image& test, const Image& reference, const MetricOptions& options) {
  check_pair(test, reference, options.channel);
  check_mask(options.mask, test);
  const int w = test.width(), h = test.height(), nc = test.channels();

  // One partial per row, summed in row order afterwards: deterministic for any thread
  // count (DESIGN.md, conventions).
  std::vector<Partial> rows(h);
  parallel_for(h, 8, [&](size_t y0, size_t y1) {
    std::vector<float> a(nc), b(nc);
    for (size_t y = y0; y < y1; ++y) {
      Partial& r = rows[y];
      for (int x = 0; x < w; ++x) {
        size_t i = y * w + x;
        if (options.mask && !(options.mask->data()[i] >= 0.5f)) continue;
        int n = select_values(test, i, options.channel, a.data());
        select_values(reference, i, options.channel, b.data());
        double pixel_max = 0;
        for (int k = 0; k < n; ++k) {
          double e = double(a[k]) - double(b[k]);
          double ae = std::abs(e);
          r.sum_abs += ae;
          r.sum_sq += e * e;
          r.sum_signed += e;
          // NaN propagates to max_abs through the comparison being false; keep it visible.
          if (!(ae <= r.max_abs)) r.max_abs = ae;
          if (!(ae <= pixel_max)) pixel_max = ae;
          r.ref_max = std::max(r.ref_max, double(b[k]));
        }
        ++r.pixels;
        r.values += n;
        if (pixel_max > options.threshold || std::isnan(pixel_max)) ++r.above;
      }
    }
  });

  Partial t;
  for (const Partial& r : rows) {
    t.sum_abs += r.sum_abs;
    t.sum_sq += r.sum_sq;
    t.sum_signed += r.sum_signed;
    if (!(r.max_abs <= t.max_abs)) t.max_abs = r.max_abs;
    t.ref_max = std::max(t.ref_max, r.ref_max);
    t.pixels += r.pixels;
    t.values += r.values;
    t.above += r.above;
  }
  if (t.pixels == 0) throw Error("the mask selects no pixel of the {}x{} images", w, h);

  ErrorStats s;
  s.pixels = t.pixels;
  s.values = t.values;
  double n = double(t.values);
  s.mae = t.sum_abs / n;
  double mse = t.sum_sq / n;
  s.rmse = std::sqrt(mse);
  s.max_abs = t.max_abs;
  s.mean_signed = t.sum_signed / n;
  s.peak = options.peak == PeakMode::kOne ? 1.0 : t.ref_max;
  if (!(s.peak > 0))
    s.psnr = std::numeric_limits<double>::quiet_NaN();  // no meaningful peak
  else
    s.psnr = mse == 0 ? std::numeric_limits<double>::infinity()
                      : 10.0 * std::log10(s.peak * s.peak / mse);
  s.fraction_above = double(t.above) / double(t.pixels);
  return s;
}

double mean_absolute_error(const Image& test, const Image& reference, const MetricOptions& o) {
  return compare_images(test, reference, o).mae;
}
double rmse(const Image& test, const Image& reference, const MetricOptions& o) {
  return compare_images(test, reference, o).rmse;
}
double max_absolute_error(const Image& test, const Image& reference, const MetricOptions& o) {
  return compare_images(test, reference, o).max_abs;
}
double psnr(const Image& test, const Image& reference, const MetricOptions& o) {
  return compare_images(test, reference, o).psnr;
}
double mean_signed_error(const Image& test, const Image& reference, const MetricOptions& o) {
  return compare_images(test, reference, o).mean_signed;
}
double fraction_above(const Image& test, const Image& reference, double threshold,
                      const MetricOptions& o) {
  MetricOptions opts = o;
  opts.threshold = threshold;
  return compare_images(test, reference, opts).fraction_above;
}

Image difference_map(const Image& test, const Image& reference, ChannelSelect channel) {
  check_pair(test, reference, channel);
  Image out(test.width(), test.height(), 1);
  const int nc = test.channels();
  parallel_for(test.pixel_count(), 4096, [&](size_t i0, size_t i1) {
    std::vector<float> a(nc), b(nc);
    for (size_t i = i0; i < i1; ++i) {
      int n = select_values(test, i, channel, a.data());
      select_values(reference, i, channel, b.data());
      double sum = 0;
      for (int k = 0; k < n; ++k) sum += double(a[k]) - double(b[k]);
      out.data()[i] = float(sum / n);
    }
  });
  return out;
}

}  // namespace penumbra
