// Sampling routines shared by every method: stratified light-sample sets on the unit
// square (agrawala2000 §3), warps from the square to disks and cones.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/sampling_shared.h"

namespace penumbra {

// Factor n into a cols x rows grid, as square as possible (rows <= cols, rows * cols = n):
// 256 -> 16 x 16, 128 -> 16 x 8, 100 -> 10 x 10, 7 -> 7 x 1.
void stratification_grid(int n, int* cols, int* rows);

// n stratified, jittered points on [0,1)^2: one per cell of a stratification_grid(n),
// cell-major (row by row). With jitter=false the cell centres.
std::vector<Vec2f> stratified_samples(int n, Rng& rng, bool jitter = true);

// The cells of stratification_grid(n), factored once: sample(i, u) is cell i (row by row)
// jittered by u in [0,1)^2.
class StratifiedGrid {
 public:
  explicit StratifiedGrid(int n);
  int size() const { return cols_ * rows_; }
  Vec2f sample(int i, Vec2f u) const { return shader::stratified_cell(i, cols_, inv_cols_, inv_rows_, u); }
  // What the GPU kernels take to draw the same cells (sampling_shared.h stratified_cell).
  int cols() const { return cols_; }
  float inv_cols() const { return inv_cols_; }
  float inv_rows() const { return inv_rows_; }

 private:
  int cols_ = 1, rows_ = 1;
  float inv_cols_ = 1, inv_rows_ = 1;
};

// Stratified sample `i` of `n` (cell i of stratification_grid(n)) jittered by u in [0,1)^2.
// (Factors n on every call: loops should hold a StratifiedGrid.)
Vec2f stratified_sample(int i, int n, Vec2f u);

// The shared light-sample set of a frame. agrawala2000 §3: "the same light samples are
// used for all surface points" (fixed: banding, no noise), or decorrelated per pixel by a
// Cranley-Patterson rotation keyed by the pixel (noise, no banding).
class LightSampleSet {
 public:
  LightSampleSet() = default;
  // n stratified samples drawn with `seed`; per_pixel selects the decorrelated mode.
  LightSampleSet(int n, uint64_t seed, bool per_pixel);
  int size() const { return static_cast<int>(base_.size()); }
  bool per_pixel() const { return per_pixel_; }
  // Sample i for the given pixel (the pixel is ignored in the fixed mode).
  Vec2f sample(int i, uint32_t pixel) const;
  const std::vector<Vec2f>& base() const { return base_; }

 private:
  std::vector<Vec2f> base_;
  uint64_t seed_ = 0;
  bool per_pixel_ = false;
};

// A piecewise-constant density on [0,1]^2 from a width x height grid of non-negative values
// (cell (x, y) covers [x, x+1]/width x [y, y+1]/height, row y = 0 at v = 0), sampled by
// inverting the marginal over rows and the row's conditional (pbrt-v4's PiecewiseConstant2D):
// importance sampling of a textured light by its texels (issue 20 part 3). The warp is
// continuous and monotonic in each coordinate, so stratified inputs stay stratified. A grid
// that sums to zero samples uniformly.
class PiecewiseConstant2D {
 public:
  PiecewiseConstant2D() = default;
  PiecewiseConstant2D(const std::vector<float>& values, int width, int height);
  int width() const { return width_; }
  int height() const { return height_; }
  // The point for u in [0,1)^2.
  Vec2f sample(Vec2f u) const;
  // Its density with respect to area on [0,1]^2 (1 for a constant grid).
  float pdf(Vec2f p) const;
  // The mean of the values.
  float mean() const { return mean_; }
  // The tables sample() inverts (what the GPU uploads): height + 1 marginal entries, then
  // height rows of width + 1 conditional ones.
  const std::vector<float>& marginal_cdf() const { return marginal_cdf_; }
  const std::vector<float>& conditional_cdf() const { return conditional_cdf_; }

 private:
  int width_ = 1, height_ = 1;
  float mean_ = 0;
  std::vector<float> values_;          // row-major, normalised to mean 1 (all 1 when the sum is 0)
  std::vector<float> marginal_cdf_;    // height + 1
  std::vector<float> conditional_cdf_;  // height rows of width + 1
};

// Shirley-Chiu concentric map from [0,1)^2 to the unit disk: keeps strata compact.
Vec2f square_to_disk_concentric(Vec2f u);
// Uniform direction inside a cone of half-angle acos(cos_max) around +z.
Vec3f square_to_cone(Vec2f u, float cos_max);
inline float cone_pdf(float cos_max) { return shader::uniform_cone_pdf(cos_max); }

}  // namespace penumbra
