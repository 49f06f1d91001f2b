#include "penumbra/core/sampling.h"

#include <algorithm>
#include <cmath>

#include "penumbra/core/error.h"

namespace penumbra {

void stratification_grid(int n, int* cols, int* rows) {
  if (n <= 0) throw Error("stratification_grid: sample count must be positive, got {}", n);
  int r = static_cast<int>(std::sqrt(static_cast<double>(n)));
  while (r > 1 && n % r != 0) --r;
  *rows = r;
  *cols = n / r;
}

StratifiedGrid::StratifiedGrid(int n) {
  stratification_grid(n, &cols_, &rows_);
  inv_cols_ = 1.0f / cols_;
  inv_rows_ = 1.0f / rows_;
}

Vec2f stratified_sample(int i, int n, Vec2f u) { return StratifiedGrid(n).sample(i, u); }

std::vector<Vec2f> stratified_samples(int n, Rng& rng, bool jitter) {
  int cols, rows;
  stratification_grid(n, &cols, &rows);
  std::vector<Vec2f> out;
  out.reserve(n);
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < cols; ++x) {
      Vec2f u = jitter ? rng.next_2d() : Vec2f(0.5f, 0.5f);
      out.push_back({(x + u.x) / cols, (y + u.y) / rows});
    }
  return out;
}

LightSampleSet::LightSampleSet(int n, uint64_t seed, bool per_pixel) : seed_(seed), per_pixel_(per_pixel) {
  Rng rng(seed, 0x4c53u /* "LS" */);
  base_ = stratified_samples(n, rng, true);
}

Vec2f LightSampleSet::sample(int i, uint32_t pixel) const {
  Vec2f s = base_[i];
  if (!per_pixel_) return s;
  // Cranley-Patterson rotation: a toroidal shift per pixel keeps the stratification.
  Rng rng(seed_, 0x5050u, pixel);
  Vec2f shift = rng.next_2d();
  s.x += shift.x; s.y += shift.y;
  if (s.x >= 1.0f) s.x -= 1.0f;
  if (s.y >= 1.0f) s.y -= 1.0f;
  return s;
}

// sampling_shared.h: the same warps the GPU kernels use.
Vec2f square_to_disk_concentric(Vec2f u) { return shader::concentric_disk(u); }

Vec3f square_to_cone(Vec2f u, float cos_max) { return shader::uniform_cone(u, cos_max); }

PiecewiseConstant2D::PiecewiseConstant2D(const std::vector<float>& values, int width, int height)
    : width_(width), height_(height) {
  if (width < 1 || height < 1 || values.size() != static_cast<size_t>(width) * height)
    throw Error("PiecewiseConstant2D: {} values for a {} x {} grid", values.size(), width, height);
  double sum = 0;
  for (float v : values) {
    if (!(v >= 0) || !std::isfinite(v)) throw Error("PiecewiseConstant2D: value {} is not finite and >= 0", v);
    sum += v;
  }
  const size_t n = values.size();
  mean_ = static_cast<float>(sum / static_cast<double>(n));
  values_.resize(n);
  for (size_t i = 0; i < n; ++i) values_[i] = sum > 0 ? static_cast<float>(values[i] / (sum / static_cast<double>(n))) : 1.0f;
  // Conditional CDFs per row (each ending at 1), then the marginal over the rows' sums.
  conditional_cdf_.assign(static_cast<size_t>(height) * (width + 1), 0.0f);
  marginal_cdf_.assign(height + 1, 0.0f);
  std::vector<double> row_sum(height, 0.0);
  for (int y = 0; y < height; ++y) {
    float* cdf = &conditional_cdf_[static_cast<size_t>(y) * (width + 1)];
    double acc = 0;
    for (int x = 0; x < width; ++x) {
      acc += values_[static_cast<size_t>(y) * width + x];
      cdf[x + 1] = static_cast<float>(acc);
    }
    row_sum[y] = acc;
    for (int x = 1; x <= width; ++x) cdf[x] = acc > 0 ? static_cast<float>(cdf[x] / acc) : static_cast<float>(x) / width;
    cdf[width] = 1.0f;
  }
  double acc = 0, total = 0;
  for (double r : row_sum) total += r;
  for (int y = 0; y < height; ++y) {
    acc += row_sum[y];
    marginal_cdf_[y + 1] = static_cast<float>(acc / total);
  }
  marginal_cdf_[height] = 1.0f;
}

Vec2f PiecewiseConstant2D::sample(Vec2f u) const {
  return shader::piecewise_constant_2d_sample(marginal_cdf_.data(), conditional_cdf_.data(), width_, height_, u);
}

float PiecewiseConstant2D::pdf(Vec2f p) const {
  const int x = std::clamp(static_cast<int>(p.x * width_), 0, width_ - 1);
  const int y = std::clamp(static_cast<int>(p.y * height_), 0, height_ - 1);
  return values_[static_cast<size_t>(y) * width_ + x];
}

}  // namespace penumbra
