#include "penumbra/core/sampling.h"

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

}  // namespace penumbra
