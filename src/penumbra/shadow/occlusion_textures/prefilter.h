// The three pre-filtering schemes of eisemann2006 §3.2 for a stack of binary occlusion
// textures (one per slice): each answers "the mean coverage of slice k over the rectangle
// [x0, x1] x [y0, y1]" (texel space: x right, y down, texel (i, j) is the square
// [i, i+1) x [j, j+1), holding 0 or 1) with a fixed number of texel reads, whatever the
// rectangle's size. Outside the texture counts as empty; the mean is over the whole
// rectangle.
//
// - MipmapFilter: dyadic means (level l texel = mean of a 2^l x 2^l aligned block), trilinear
//   lookups (8 texel reads; the level is log2 of the kernel side, clamped to the edge within
//   a level), anisotropic rectangles as up to 16 trilinear lookups along the long side (as
//   GPUs do). Blocky where dyadic blocks do not line up with the kernel.
// - NBufferFilter: Décoret's N-buffers with means: level l holds, for *every* texel, the mean
//   over the 2^l x 2^l box whose top-left corner it is. A square kernel of side q in
//   [2^l, 2^(l+1)] is the linear interpolation (in q) of the bilinearly interpolated level-l
//   and level-(l+1) boxes centred on it (8 texel reads): exact for q = 2^l, close in between.
// - SatFilter: summed-area tables, the exact box filter of the piecewise-constant texture at
//   any real position and size: the integral image is bilinear inside each texel, so the four
//   corners are bilinear interpolations of the table (16 texel reads), evaluated as an exact
//   integer count plus small fractional terms (no cancellation of large numbers).
//
// Mipmaps and N-buffers store 8-bit means (255 = covered), as the paper's RGBA8 textures do.
// Everything is stored slice by slice (one plane per slice and level): a lookup reads one
// slice, and neighbouring view samples read neighbouring texels of it. Summed-area tables
// are exact counts in 32-bit integers (any table up to 4096^2 texels) or doubles.
//
// Two entry points per filter: box() for any rectangle, one at a time, and squares() for a
// batch of square kernels on one slice (the shading loop): its coordinate arithmetic runs
// over the batch in vectorisable loops, then the texel reads. A square partly outside the
// texture is cut to it; when the cut is elongated (more than 5:4) the mipmap and N-buffer
// batches send it through box() (several square lookups) unless it misses every texel the
// slice covers (then 0, the exact box filter, without reads). Both entry points give the
// same value for a square inside the texture.
// Texture sizes are powers of two (the caller checks).
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "penumbra/shadow/occlusion_textures/occlusion_shared.h"

// The batched lookups are compiled twice, for AVX2 and for the baseline x86-64 (SSE2), and
// the first call picks the version the processor runs (GCC function multiversioning; the
// same IEEE operations either way: no FMA contraction under -std=c++20, so results do not
// depend on the processor). About 1.4x faster lookups where AVX2 is available.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(__AVX2__)
#define PENUMBRA_OT_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define PENUMBRA_OT_CLONES
#endif

namespace penumbra::occlusion {

// Texel reads of the lookups made (for statistics and the light-size-independence test).
struct LookupCounters {
  uint64_t lookups = 0;  // filtered lookups (one per kernel)
  uint64_t reads = 0;    // texels read
  uint64_t outside = 0;  // kernels entirely outside the texture (0, nothing read)
  uint64_t strips = 0;   // kernels cut by the border to an elongated rectangle (mipmap, N-buffer)
};

// The coverage stack the filters are built from: bit k of masks[y * width + x] = slice k
// covers texel (x, y).
struct CoverageStack {
  int width = 0, height = 0, slices = 0;
  std::span<const uint32_t> masks;
};

// The texels a slice covers, as a rectangle [x0, x1) x [y0, y1) (empty: x0 >= x1).
struct SliceBounds {
  float x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool meets(float ax0, float ay0, float ax1, float ay1) const { return ax0 < x1 && ax1 > x0 && ay0 < y1 && ay1 > y0; }
};
std::vector<SliceBounds> coverage_bounds(const CoverageStack& c);

class BytePyramid;
// A pyramid as the shared lookups read it (occlusion_shared.h OtTextures).
shader::OtTextures pyramid_textures(uint32_t prefilter, int width, int height, const BytePyramid& pyramid);

// Levels of 8-bit planes, one plane per (level, slice), with a padding row after the last
// plane so that bilinear reads at the far edge (weighted 0) stay inside the allocation.
class BytePyramid {
 public:
  struct Plane {
    const uint8_t* data = nullptr;
    int w = 0, h = 0;  // texels (mipmap) or anchors (N-buffer) per row and column
  };
  void allocate(int levels, int slices, const std::vector<std::pair<int, int>>& sizes);
  // What allocate() allocates for these level sizes (for memory estimates).
  static uint64_t bytes(int slices, const std::vector<std::pair<int, int>>& sizes);
  const Plane& plane(int l, int k) const { return planes_[static_cast<size_t>(k) * levels_ + l]; }
  // Slice k's planes, level by level.
  const Plane* planes(int k) const { return planes_.data() + static_cast<size_t>(k) * levels_; }
  uint8_t* mutable_plane(int l, int k) { return const_cast<uint8_t*>(plane(l, k).data); }
  int levels() const { return levels_; }
  int slices() const { return slices_; }
  size_t bytes() const { return data_.size(); }
  // The 2 x 2 bytes at p (row stride w) as one word: p[0], p[1], p[w], p[w + 1] from the low byte
  // up (two 16-bit reads).
  static uint32_t quad(const uint8_t* p, int w) {
    uint16_t top, bottom;
    std::memcpy(&top, p, 2);
    std::memcpy(&bottom, p + w, 2);
    return uint32_t{top} | (uint32_t{bottom} << 16);
  }
  // Bilinear blend of a quad(), in [0, 1].
  static float bilinear(uint32_t q, float fx, float fy) {
    const float a = float(q & 0xffu), b = float((q >> 8) & 0xffu), c = float((q >> 16) & 0xffu), d = float(q >> 24);
    const float top = a + (b - a) * fx, bottom = c + (d - c) * fx;
    return (top + (bottom - top) * fy) * (1.0f / 255.0f);
  }

 private:
  int levels_ = 0, slices_ = 0;
  std::vector<Plane> planes_;  // slice-major: planes_[k * levels + l]
  std::vector<uint8_t> data_;
};

class MipmapFilter {
 public:
  void build(const CoverageStack& c);
  // The levels' sizes of a width x height stack, and what its pyramid holds.
  static std::vector<std::pair<int, int>> level_sizes(int width, int height);
  static uint64_t bytes(int width, int height, int slices) {
    return BytePyramid::bytes(slices, level_sizes(width, height));
  }
  float box(int k, float x0, float y0, float x1, float y1, LookupCounters& n) const;
  void squares(int k, size_t count, const float* cx, const float* cy, const float* side, float* out,
               LookupCounters& n) const;
  size_t memory_bytes() const { return pyramid_.bytes(); }
  int levels() const { return pyramid_.levels(); }
  int level_width(int l) const { return level_side(width_, l); }
  int level_height(int l) const { return level_side(height_, l); }
  static int level_side(int side, int l) { return std::max(1, side >> l); }
  // Level l's value of slice k at texel (x, y), in [0, 1].
  float texel(int l, int k, int x, int y) const {
    const auto& p = pyramid_.plane(l, k);
    return p.data[static_cast<size_t>(y) * p.w + x] * (1.0f / 255.0f);
  }
  // One trilinear lookup for a square of side `side` centred on (cx, cy).
  float trilinear(int k, float cx, float cy, float side, LookupCounters& n) const;
  // The textures as the shared lookups read them (occlusion_shared.h).
  shader::OtTextures shared() const;
  const std::vector<SliceBounds>& bounds() const { return bounds_; }

 private:
  int width_ = 0, height_ = 0;
  BytePyramid pyramid_;
  std::vector<SliceBounds> bounds_;
};

class NBufferFilter {
 public:
  void build(const CoverageStack& c);
  // The levels' sizes of a width x height stack, and what its pyramid holds.
  static std::vector<std::pair<int, int>> level_sizes(int width, int height);
  static uint64_t bytes(int width, int height, int slices) {
    return BytePyramid::bytes(slices, level_sizes(width, height));
  }
  float box(int k, float x0, float y0, float x1, float y1, LookupCounters& n) const;
  void squares(int k, size_t count, const float* cx, const float* cy, const float* side, float* out,
               LookupCounters& n) const;
  size_t memory_bytes() const { return pyramid_.bytes(); }
  int levels() const { return pyramid_.levels(); }
  // Anchors per row and column of level l: the boxes [x, x + 2^l) that lie inside.
  int level_width(int l) const { return level_side(width_, l); }
  int level_height(int l) const { return level_side(height_, l); }
  static int level_side(int side, int l) { return side - (1 << l) + 1; }
  // Level l's value of slice k for the box with top-left texel (x, y), in [0, 1].
  float texel(int l, int k, int x, int y) const {
    const auto& p = pyramid_.plane(l, k);
    return p.data[static_cast<size_t>(y) * p.w + x] * (1.0f / 255.0f);
  }
  // One lookup for a square of side `side` centred on (cx, cy) (anchors clamped inside).
  float square(int k, float cx, float cy, float side, LookupCounters& n) const;
  // The textures as the shared lookups read them (occlusion_shared.h).
  shader::OtTextures shared() const;
  const std::vector<SliceBounds>& bounds() const { return bounds_; }

 private:
  int width_ = 0, height_ = 0;
  BytePyramid pyramid_;
  std::vector<SliceBounds> bounds_;
};

// T = uint32_t (exact counts) or double.
template <class T>
class SatFilter {
 public:
  void build(const CoverageStack& c);
  float box(int k, float x0, float y0, float x1, float y1, LookupCounters& n) const;
  void squares(int k, size_t count, const float* cx, const float* cy, const float* side, float* out,
               LookupCounters& n) const;
  size_t memory_bytes() const { return data_.size() * sizeof(T); }
  // What the tables of a width x height stack hold: (width + 1) x (height + 1) per slice.
  static uint64_t bytes(int width, int height, int slices) {
    return (static_cast<uint64_t>(width) + 1) * (static_cast<uint64_t>(height) + 1) * static_cast<uint64_t>(slices) *
           sizeof(T);
  }
  // The table of slice k: (width + 1) x (height + 1), entry (x, y) = covered texels in
  // [0, x) x [0, y).
  T entry(int k, int x, int y) const {
    return data_[static_cast<size_t>(k) * slice_size_ + static_cast<size_t>(y) * stride_ + x];
  }
  // The tables as the shared lookups read them (occlusion_shared.h).
  shader::OtTextures shared() const;

 private:
  int width_ = 0, height_ = 0;
  size_t stride_ = 0, slice_size_ = 0;
  std::vector<T> data_;
};

}  // namespace penumbra::occlusion
