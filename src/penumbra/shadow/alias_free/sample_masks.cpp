#include "penumbra/shadow/alias_free/sample_masks.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"

namespace penumbra::afsm {
namespace {

// The point on the unit diamond |x| + |y| = 1 whose diamond_angle is a (inverse of it).
Vec2f diamond_point(float a) {
  if (a <= 1) return {1 - a, a};
  if (a <= 2) return {1 - a, 2 - a};
  if (a <= 3) return {a - 3, 2 - a};
  return {a - 3, a - 4};
}

// Margin (in units of the samples' radius) under which a cell does not trust its
// classification: covers the rounding of the diamond angle, of the distance and of g . u + h.
constexpr float kMargin = 1e-5f;

}  // namespace

LightSamples make_light_samples(const AreaLight& light, int n, uint64_t seed, int light_index, int frame) {
  if (n < 1 || n > kMaxLightSamples)
    throw Error("afsm: light samples (--spp) must be in [1, {}], got {}", kMaxLightSamples, n);
  return penumbra::make_light_samples(light, n, seed, light_index, frame);
}

PlaneMaskLut::PlaneMaskLut(std::span<const Vec2f> samples, int angle_bins, int distance_bins)
    : words_(mask_words(static_cast<int>(samples.size()))),
      angle_bins_(angle_bins > 0 && distance_bins > 0 ? angle_bins : 0),
      distance_bins_(angle_bins > 0 && distance_bins > 0 ? distance_bins : 0) {
  const int n = static_cast<int>(samples.size());
  if (n < 1 || n > kMaxLightSamples) throw Error("afsm: {} light samples (must be in [1, {}])", n, kMaxLightSamples);
  float rmax = 0;
  for (Vec2f u : samples) {
    ux_.push_back(u.x);
    uy_.push_back(u.y);
    rmax = std::max(rmax, std::sqrt(u.x * u.x + u.y * u.y));
  }
  max_distance_ = rmax * (1 + 1e-4f) + 1e-6f;
  max_distance2_ = max_distance_ * max_distance_;
  all_.assign(words_, ~0ull);
  if (n % 64) all_.back() = (1ull << (n % 64)) - 1;
  if (!has_table()) return;

  // Each sample u = r (cos phi, sin phi); a line (cos theta, sin theta) . u > d puts it on the
  // positive side iff r cos(theta - phi) > d. Over a cell theta in [t0, t1], d in [d0, d1]:
  // sure when r min cos - d1 > margin, surely not when r max cos - d0 < -margin.
  cells_.assign(static_cast<size_t>(angle_bins_) * distance_bins_ * 2 * words_, 0);
  const float d_step = 2 * max_distance_ / distance_bins_;
  parallel_for(angle_bins_, 1, [&](size_t a_begin, size_t a_end) {
    std::vector<float> lo(n), hi(n);
    for (size_t a = a_begin; a < a_end; ++a) {
      const Vec2f p0 = diamond_point(4.0f * a / angle_bins_), p1 = diamond_point(4.0f * (a + 1) / angle_bins_);
      double t0 = std::atan2(p0.y, p0.x), t1 = std::atan2(p1.y, p1.x);
      if (t1 < t0) t1 += 2 * kPi;
      for (int i = 0; i < n; ++i) {
        const double r = std::sqrt(double(ux_[i]) * ux_[i] + double(uy_[i]) * uy_[i]);
        const double phi = std::atan2(uy_[i], ux_[i]);
        double c0 = std::cos(t0 - phi), c1 = std::cos(t1 - phi);
        double cmin = std::min(c0, c1), cmax = std::max(c0, c1);
        auto inside = [&](double angle) {  // angle in [t0, t1] modulo 2 pi
          double delta = std::fmod(angle - t0, 2 * kPi);
          if (delta < 0) delta += 2 * kPi;
          return delta <= t1 - t0;
        };
        if (inside(phi)) cmax = 1;
        if (inside(phi + kPi)) cmin = -1;
        lo[i] = static_cast<float>(r * cmin);
        hi[i] = static_cast<float>(r * cmax);
      }
      for (int b = 0; b < distance_bins_; ++b) {
        const float d0 = -max_distance_ + b * d_step, d1 = d0 + d_step;
        uint64_t* sure = cells_.data() + (a * distance_bins_ + b) * 2 * words_;
        uint64_t* unsure = sure + words_;
        for (int i = 0; i < n; ++i) {
          const uint64_t bit = 1ull << (i & 63);
          if (lo[i] - d1 > kMargin)
            sure[i >> 6] |= bit;
          else if (!(hi[i] - d0 < -kMargin))
            unsure[i >> 6] |= bit;
        }
      }
    }
  });
}

uint64_t PlaneMaskLut::bytes(int n, int angle_bins, int distance_bins) {
  const uint64_t words = static_cast<uint64_t>(mask_words(n));
  const uint64_t cells = angle_bins > 0 && distance_bins > 0
                             ? static_cast<uint64_t>(angle_bins) * static_cast<uint64_t>(distance_bins)
                             : 0;
  return (cells * 2 + 1) * words * sizeof(uint64_t) + 2 * 2 * static_cast<uint64_t>(n) * sizeof(float);
}

size_t PlaneMaskLut::memory_bytes() const {
  return cells_.size() * sizeof(uint64_t) + (ux_.size() + uy_.size()) * sizeof(float);
}

void PlaneMaskLut::exact(Vec2f g, float h, uint64_t* out) const {
  const int n = size();
  for (int w = 0; w < words_; ++w) {
    const int base = w * 64, count = std::min(64, n - base);
    uint64_t bits = 0;
    for (int b = 0; b < count; ++b)
      bits |= static_cast<uint64_t>(above(ux_[base + b], uy_[base + b], g, h)) << b;
    out[w] = bits;
  }
}

int PlaneMaskLut::lookup(Vec2f g, float h, uint64_t* out) const {
  // The cell (alias_free_shared.h: the GPU's lookup too).
  const int cell = shader::afsm_lut_cell(g, h, max_distance_, angle_bins_, distance_bins_);
  // Every sample lies within max_distance_ of the centre: the line misses the disk.
  if (cell == shader::kAfsmLutNone) {
    std::fill(out, out + words_, 0ull);
    return 0;
  }
  if (cell == shader::kAfsmLutAll) {
    std::copy(all_.begin(), all_.end(), out);
    return 0;
  }
  const uint64_t* sure = cells_.data() + static_cast<size_t>(cell) * 2 * words_;
  const uint64_t* unsure = sure + words_;
  int tested = 0;
  for (int w = 0; w < words_; ++w) {
    uint64_t bits = sure[w];
    for (uint64_t u = unsure[w]; u; u &= u - 1) {
      const int i = w * 64 + std::countr_zero(u);
      bits |= static_cast<uint64_t>(above(ux_[i], uy_[i], g, h)) << (i & 63);
      ++tested;
    }
    out[w] = bits;
  }
  return tested;
}

uint64_t SampleGrid::bytes(int n) {
  // first_ (about one cell a sample), each sample's cell while sorting and a cursor per cell,
  // index_, and x_ and y_ padded.
  const uint64_t samples = static_cast<uint64_t>(n);
  return 3 * (samples + 1) * sizeof(uint32_t) + samples * sizeof(uint16_t) + 2 * (samples + 64) * sizeof(float);
}

SampleGrid::SampleGrid(std::span<const Vec2f> samples, float per_cell) {
  const int n = static_cast<int>(samples.size());
  if (n < 1 || n > kMaxLightSamples) throw Error("afsm: {} light samples (must be in [1, {}])", n, kMaxLightSamples);
  cells_ = std::max(1, static_cast<int>(std::lround(std::sqrt(n / std::max(per_cell, 1e-3f)))));
  float& x1 = x1_;
  float& y1 = y1_;
  x1 = -kInfinity, y1 = -kInfinity;
  x0_ = kInfinity, y0_ = kInfinity;
  reach_ = 0;
  for (Vec2f u : samples) {
    x0_ = std::min(x0_, u.x), y0_ = std::min(y0_, u.y), x1 = std::max(x1, u.x), y1 = std::max(y1, u.y);
    reach_ = std::max({reach_, std::abs(double(u.x)), std::abs(double(u.y))});
  }
  inv_w_ = x1 > x0_ ? cells_ / (x1 - x0_) : 1.0f;
  inv_h_ = y1 > y0_ ? cells_ / (y1 - y0_) : 1.0f;
  // Counting sort by cell (row-major), samples in index order inside a cell.
  std::vector<uint32_t> cell(n);
  first_.assign(static_cast<size_t>(cells_) * cells_ + 1, 0);
  for (int i = 0; i < n; ++i) {
    cell[i] = static_cast<uint32_t>(cell_y(samples[i].y) * cells_ + cell_x(samples[i].x));
    first_[cell[i] + 1]++;
  }
  for (size_t c = 1; c < first_.size(); ++c) first_[c] += first_[c - 1];
  std::vector<uint32_t> next(first_.begin(), first_.end() - 1);
  // (x_ and y_ padded for whole SIMD vectors: pair_filter's inside_cells.)
  index_.resize(n), x_.resize(n + 64, 0.0f), y_.resize(n + 64, 0.0f);
  for (int i = 0; i < n; ++i) {
    const uint32_t at = next[cell[i]]++;
    index_[at] = static_cast<uint16_t>(i);
    x_[at] = samples[i].x;
    y_[at] = samples[i].y;
  }
}

// Monotone in ux (a subtraction and a product by a positive constant, each rounded), so a
// sample between two bounds lies in a cell between theirs.
int SampleGrid::cell_x(float ux) const {
  const float f = (ux - x0_) * inv_w_;
  return f <= 0 ? 0 : f >= static_cast<float>(cells_ - 1) ? cells_ - 1 : static_cast<int>(f);
}
int SampleGrid::cell_y(float uy) const {
  const float f = (uy - y0_) * inv_h_;
  return f <= 0 ? 0 : f >= static_cast<float>(cells_ - 1) ? cells_ - 1 : static_cast<int>(f);
}

bool SampleGrid::triangle_cells(const Line lines[3], int max_cells, Range* out) const {
  // above() computes g.x u.x + g.y u.y + h in float: at most 2 roundings of terms bounded by
  // S = |g.x| reach + |g.y| reach + |h|, so a sample it puts on the positive side satisfies
  // g . u + h >= -2^-22 S exactly. Relax each line by 2^-18 S and bound that triangle.
  double gx[3], gy[3], h[3];
  for (int k = 0; k < 3; ++k) {
    gx[k] = lines[k].g.x, gy[k] = lines[k].g.y;
    h[k] = double(lines[k].h) + 0x1p-18 * ((std::abs(gx[k]) + std::abs(gy[k])) * reach_ + std::abs(double(lines[k].h)));
  }
  // The positive sides meet in a bounded triangle (or nothing) iff the normals positively
  // span the plane: the three cross products of consecutive normals share a strict sign
  // (products of floats are exact in double, so the signs are exact).
  double c[3];
  for (int k = 0; k < 3; ++k) {
    const int j = (k + 1) % 3;
    c[k] = gx[k] * gy[j] - gy[k] * gx[j];
  }
  if (!((c[0] > 0 && c[1] > 0 && c[2] > 0) || (c[0] < 0 && c[1] < 0 && c[2] < 0))) return false;
  double bx0 = kInfinity, by0 = kInfinity, bx1 = -kInfinity, by1 = -kInfinity;
  for (int k = 0; k < 3; ++k) {
    const int j = (k + 1) % 3;
    const double x = (h[j] * gy[k] - h[k] * gy[j]) / c[k];
    const double y = (h[k] * gx[j] - h[j] * gx[k]) / c[k];
    bx0 = std::min(bx0, x), bx1 = std::max(bx1, x), by0 = std::min(by0, y), by1 = std::max(by1, y);
  }
  if (!(bx1 - bx0 < 1e30 && by1 - by0 < 1e30)) return false;  // (nearly) parallel lines
  // The vertices' own rounding (a few ulps of double) is far below the relaxation; widen by
  // a float ulp more so that converting the bounds to float keeps them outside.
  const double pad = 1e-6 * (1 + reach_);
  bx0 -= pad, by0 -= pad, bx1 += pad, by1 += pad;
  const double lo = -2 * reach_ - 1, hi = 2 * reach_ + 1;  // outside the samples: clamp
  if (bx1 < -reach_ || by1 < -reach_ || bx0 > reach_ || by0 > reach_) {
    *out = {0, 0, -1, -1};
    return true;
  }
  out->x0 = cell_x(static_cast<float>(std::clamp(bx0, lo, hi)));
  out->x1 = cell_x(static_cast<float>(std::clamp(bx1, lo, hi)));
  out->y0 = cell_y(static_cast<float>(std::clamp(by0, lo, hi)));
  out->y1 = cell_y(static_cast<float>(std::clamp(by1, lo, hi)));
  return (out->x1 - out->x0 + 1) * (out->y1 - out->y0 + 1) <= max_cells;
}

}  // namespace penumbra::afsm
