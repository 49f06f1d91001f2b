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
  LightSamples out;
  out.center = light.center;
  out.s = light.frame.s;
  out.t = light.frame.t;
  out.n = light.frame.n;
  out.radius = std::max(light.extent_radius(), 1e-20f);
  const LightSampleSet set(n, hash_combine(hash_combine(seed, 0x4146534du /* "AFSM" */ + light_index), frame),
                           /*per_pixel=*/false);
  const float inv_r = 1.0f / out.radius;
  for (int i = 0; i < n; ++i) {
    const Vec3f q = light.sample_area(set.sample(i, 0));
    out.points.push_back(q);
    const Vec3f d = q - out.center;
    out.local.push_back({dot(d, out.s) * inv_r, dot(d, out.t) * inv_r});
  }
  return out;
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

size_t PlaneMaskLut::memory_bytes() const {
  return cells_.size() * sizeof(uint64_t) + (ux_.size() + uy_.size()) * sizeof(float);
}

void PlaneMaskLut::exact(Vec2f g, float h, uint64_t* out) const {
  const int n = size();
  for (int w = 0; w < words_; ++w) {
    const int base = w * 64, count = std::min(64, n - base);
    uint64_t bits = 0;
    for (int b = 0; b < count; ++b)
      bits |= static_cast<uint64_t>(ux_[base + b] * g.x + uy_[base + b] * g.y + h > 0) << b;
    out[w] = bits;
  }
}

int PlaneMaskLut::lookup(Vec2f g, float h, uint64_t* out) const {
  const float len = std::sqrt(g.x * g.x + g.y * g.y);
  const float d = len > 0 ? -h / len : (h > 0 ? -kInfinity : kInfinity);
  // Every sample lies within max_distance_ of the centre: the line misses the disk.
  if (!(d < max_distance_)) {
    std::fill(out, out + words_, 0ull);
    return 0;
  }
  if (d <= -max_distance_) {
    std::copy(all_.begin(), all_.end(), out);
    return 0;
  }
  const int a = std::min(static_cast<int>(diamond_angle(g.x, g.y) * (angle_bins_ * 0.25f)), angle_bins_ - 1);
  const int b = std::clamp(static_cast<int>((d + max_distance_) * (distance_bins_ / (2 * max_distance_))), 0,
                           distance_bins_ - 1);
  const uint64_t* sure = cells_.data() + (static_cast<size_t>(a) * distance_bins_ + b) * 2 * words_;
  const uint64_t* unsure = sure + words_;
  int tested = 0;
  for (int w = 0; w < words_; ++w) {
    uint64_t bits = sure[w];
    for (uint64_t u = unsure[w]; u; u &= u - 1) {
      const int i = w * 64 + std::countr_zero(u);
      bits |= static_cast<uint64_t>(ux_[i] * g.x + uy_[i] * g.y + h > 0) << (i & 63);
      ++tested;
    }
    out[w] = bits;
  }
  return tested;
}

}  // namespace penumbra::afsm
