// The light samples of sintorn2008 §4.2 as bits of a mask, and the lookup table from a plane
// to the mask of the samples on its positive side.
//
// Every light this method handles is sampled on a plane through the light's centre (rect and
// disk: the emitter; sphere: the disk facing frame.n, as AreaLight::sample_area does;
// ellipsoid: A of that disk, its central ellipse facing frame.n), so a
// plane in space meets the samples' plane in a line: the paper's "two angles and a distance"
// reduce to one angle and a distance. Samples are stored in the light's (s, t) coordinates
// divided by the light's extent radius (so they lie in the unit disk); a plane
// n . x + w > 0 becomes the line g . u + h > 0 with g = R (n.s, n.t), h = n . c + w.
//
// The table (PlaneMaskLut) is indexed by the line's direction (a pseudo-angle of g) and its
// signed distance from the centre. Each cell stores the samples that are on the positive side
// of *every* line of the cell ("sure") and those that some line of the cell puts on either
// side ("unsure", a thin band of samples around the cell's lines); a lookup ORs the sure mask
// with an exact test of the unsure samples only. The result equals the exact classification
// bit for bit (the table's discretization costs time, never accuracy): this is the paper's
// "exact-test fallback" made per sample instead of per table.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/scene/light.h"
#include "penumbra/shadow/alias_free/alias_free_shared.h"
#include "penumbra/shadow/light_samples.h"

namespace penumbra::afsm {

inline constexpr int kMaxLightSamples = 1024;

// The shared light point set (shadow/light_samples.h), bounded by the masks' size here.
using penumbra::LightSamples;
using penumbra::light_samples_bytes;
// penumbra::make_light_samples for 1 <= n <= kMaxLightSamples; throws naming --spp otherwise.
LightSamples make_light_samples(const AreaLight& light, int n, uint64_t seed, int light_index, int frame);

// Words of 64 bits for n samples.
inline int mask_words(int n) { return (n + 63) / 64; }

// The exact test of one light sample u against the line g . u + h > 0, in float, written once
// so that the table, the exact masks and the sample grid classify every sample the same way.
inline bool above(float ux, float uy, Vec2f g, float h) { return shader::afsm_above(ux, uy, g, h); }

// A line on the light's sample plane; a sample u is on its positive side when above(u, g, h).
struct Line {
  Vec2f g;
  float h;
};

class PlaneMaskLut {
 public:
  // angle_bins x distance_bins cells; 0 bins = no table (every lookup tests every sample).
  PlaneMaskLut(std::span<const Vec2f> samples, int angle_bins, int distance_bins);

  int size() const { return static_cast<int>(ux_.size()); }
  int words() const { return words_; }
  bool has_table() const { return angle_bins_ > 0; }
  size_t memory_bytes() const;
  // What a table of n samples and these bins allocates (memory_bytes before it exists; the
  // samples' coordinates grown by doubling).
  static uint64_t bytes(int n, int angle_bins, int distance_bins);

  // out[words()] = the samples u with g . u + h > 0 (table plus exact test of the unsure
  // samples; equal to exact() bit for bit). Returns the number of samples tested exactly.
  int lookup(Vec2f g, float h, uint64_t* out) const;
  // The same by testing every sample.
  void exact(Vec2f g, float h, uint64_t* out) const;
  // Both, by has_table().
  int mask(Vec2f g, float h, uint64_t* out) const {
    if (has_table()) return lookup(g, h, out);
    exact(g, h, out);
    return size();
  }
  float max_distance2() const { return max_distance2_; }
  float max_distance() const { return max_distance_; }
  int angle_bins() const { return angle_bins_; }
  int distance_bins() const { return distance_bins_; }
  // The table (has_table()): per cell (angle-major) words() sure bits, then words() unsure bits.
  std::span<const uint64_t> cells() const { return cells_; }
  // The mask with every sample set.
  const uint64_t* all() const { return all_.data(); }

  // Where the line g . u + h = 0 misses the samples' disk: -1 when no sample is on the
  // positive side, +1 when all are, 0 when it may cut them (then use mask()). No square root,
  // no table access: the common cases of the per-(sample, caster) test end here.
  // (alias_free_shared.h: the GPU's test too.)
  int side_of_disk(Vec2f g, float h) const { return shader::afsm_side_of_disk(g, h, max_distance2_); }

 private:
  std::vector<float> ux_, uy_;
  std::vector<uint64_t> all_;
  int words_ = 1;
  int angle_bins_ = 0, distance_bins_ = 0;
  float max_distance_ = 1;  // samples lie within this distance of the centre (padded)
  float max_distance2_ = 1;
  // Per cell (angle-major): words_ sure bits, then words_ unsure bits.
  std::vector<uint64_t> cells_;
};

// The light samples binned in a uniform grid of cells over their bounding box (CPU adaptation
// of §4.2's lookup; docs/methods/alias-free.md): where a triangle seen from a view sample
// projects onto the light as a small triangle (the common case with many small casters),
// only the samples of the cells its bounding box touches are tested, with the same exact
// test as the table (`above`), instead of building N-bit masks of three or four planes.
class SampleGrid {
 public:
  // About `per_cell` samples per cell on average.
  SampleGrid(std::span<const Vec2f> samples, float per_cell = 1);

  // Cells [x0, x1] x [y0, y1] (inclusive) that hold every sample which may be on the positive
  // side of all three lines by `above` (rounding included). False when the three lines do not
  // bound a triangle (their positive sides are unbounded) or the bounding box reaches over
  // more than `max_cells` cells: then the caller builds the masks plane by plane. An empty
  // range (x0 > x1) means no sample can be on the positive side of all three.
  struct Range {
    int x0, y0, x1, y1;
  };
  bool triangle_cells(const Line lines[3], int max_cells, Range* out) const;
  // What a grid of n samples allocates, at one sample per cell (the default).
  static uint64_t bytes(int n);

  int cells_x() const { return cells_; }
  // The grid's placement (for the SIMD form of triangle_cells in pair_filter): the samples
  // lie in [x0, x1] x [y0, y1]; a coordinate u is in column cell_x(u) (likewise rows);
  // reach = max |u.x|, |u.y|.
  struct Geometry {
    float x0, y0, x1, y1, inv_w, inv_h, reach;
    int cells;
  };
  Geometry geometry() const { return {x0_, y0_, x1_, y1_, inv_w_, inv_h_, static_cast<float>(reach_), cells_}; }
  // The samples of cells [x0, x1] of row y are slots [row_begin(y, x0), row_end(y, x1)) of
  // index(), x(), y() (row-major cell order).
  uint32_t row_begin(int y, int x0) const { return first_[static_cast<size_t>(y) * cells_ + x0]; }
  uint32_t row_end(int y, int x1) const { return first_[static_cast<size_t>(y) * cells_ + x1 + 1]; }
  const uint16_t* index() const { return index_.data(); }  // the sample's bit
  const uint32_t* first() const { return first_.data(); }   // row-major cells' first positions
  const float* x() const { return x_.data(); }
  const float* y() const { return y_.data(); }

 private:
  int cell_x(float ux) const;
  int cell_y(float uy) const;

  int cells_ = 1;
  float x0_ = 0, y0_ = 0, x1_ = 0, y1_ = 0, inv_w_ = 1, inv_h_ = 1;
  double reach_ = 1;  // max |u.x|, |u.y| over the samples
  std::vector<uint32_t> first_;  // cells_^2 + 1
  std::vector<uint16_t> index_;
  std::vector<float> x_, y_;
};

// A monotone stand-in for atan2 on [0, 4) (the "diamond angle"): cheaper than atan2, and
// the table's angle bins are uniform in it.
inline float diamond_angle(float x, float y) { return shader::afsm_diamond_angle(x, y); }

}  // namespace penumbra::afsm
