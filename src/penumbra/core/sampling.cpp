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

Vec2f square_to_disk_concentric(Vec2f u) {
  float ox = 2.0f * u.x - 1.0f, oy = 2.0f * u.y - 1.0f;
  if (ox == 0 && oy == 0) return {0, 0};
  float r, theta;
  if (std::abs(ox) > std::abs(oy)) {
    r = ox;
    theta = (kPi / 4) * (oy / ox);
  } else {
    r = oy;
    theta = (kPi / 2) - (kPi / 4) * (ox / oy);
  }
  return {r * std::cos(theta), r * std::sin(theta)};
}

Vec3f square_to_cone(Vec2f u, float cos_max) {
  float cos_t = (1.0f - u.x) + u.x * cos_max;
  float sin_t = std::sqrt(std::max(0.0f, 1.0f - cos_t * cos_t));
  float phi = 2.0f * kPi * u.y;
  return {std::cos(phi) * sin_t, std::sin(phi) * sin_t, cos_t};
}

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

namespace {
// Inverts a CDF of n cells (n + 1 entries from 0 to 1) at u: the cell and the position in it.
float invert_cdf(const float* cdf, int n, float u, int* cell) {
  const float* it = std::upper_bound(cdf, cdf + n + 1, u);
  // cdf[i] <= u < cdf[i + 1]: never an empty cell (u < 1 = cdf[n]).
  const int i = std::clamp(static_cast<int>(it - cdf) - 1, 0, n - 1);
  const float width = cdf[i + 1] - cdf[i];
  const float t = width > 0 ? std::clamp((u - cdf[i]) / width, 0.0f, 1.0f) : 0.5f;
  *cell = i;
  return (static_cast<float>(i) + t) / static_cast<float>(n);
}
}  // namespace

Vec2f PiecewiseConstant2D::sample(Vec2f u) const {
  int row = 0, col = 0;
  const float v = invert_cdf(marginal_cdf_.data(), height_, u.y, &row);
  const float x = invert_cdf(&conditional_cdf_[static_cast<size_t>(row) * (width_ + 1)], width_, u.x, &col);
  return {x, v};
}

float PiecewiseConstant2D::pdf(Vec2f p) const {
  const int x = std::clamp(static_cast<int>(p.x * width_), 0, width_ - 1);
  const int y = std::clamp(static_cast<int>(p.y * height_), 0, height_ - 1);
  return values_[static_cast<size_t>(y) * width_ + x];
}

}  // namespace penumbra
