#include "penumbra/shadow/occlusion_textures/prefilter.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <type_traits>

#include "penumbra/core/parallel.h"
#include "penumbra/raster/filtered_map.h"

namespace penumbra::occlusion {
namespace {

// Squares per batch step: the arrays of the coordinate pass live on the stack.
constexpr size_t kChunk = 64;


// Rounded mean of four bytes.
inline uint8_t mean4(unsigned a, unsigned b, unsigned c, unsigned d) {
  return static_cast<uint8_t>((a + b + c + d + 2) >> 2);
}

// dst[x] = mean4(a[x], a[x + n], b[x], b[x + n]) for x in [0, count): a separate function so
// the compiler sees restrict pointers and a local trip count, and vectorises it.
PENUMBRA_OT_CLONES void mean4_row(const uint8_t* __restrict a, const uint8_t* __restrict b, size_t n, uint8_t* __restrict dst,
               size_t count) {
  for (size_t x = 0; x < count; ++x) dst[x] = mean4(a[x], a[x + n], b[x], b[x + n]);
}

// o[i] = 255 where bit k of m[i] is set, else 0.
PENUMBRA_OT_CLONES void expand_row(const uint32_t* __restrict m, uint8_t* __restrict o, size_t n, int k) {
  for (size_t i = 0; i < n; ++i) o[i] = static_cast<uint8_t>(0u - ((m[i] >> k) & 1u));
}

// Level 0 of the 8-bit pyramids: one plane per slice, 255 where the slice covers the texel.
// Tasks are (slice, block of rows).
void expand_bits(const CoverageStack& c, BytePyramid& pyramid) {
  const size_t rows_per_task = std::max(1, 32768 / std::max(1, c.width));
  const size_t blocks = (static_cast<size_t>(c.height) + rows_per_task - 1) / rows_per_task;
  parallel_for(blocks * c.slices, 1, [&](size_t t0, size_t t1) {
    for (size_t t = t0; t < t1; ++t) {
      const int k = static_cast<int>(t / blocks);
      const size_t y0 = (t % blocks) * rows_per_task, y1 = std::min<size_t>(c.height, y0 + rows_per_task);
      const size_t begin = y0 * c.width, end = y1 * c.width;
      expand_row(c.masks.data() + begin, pyramid.mutable_plane(0, k) + begin, end - begin, k);
    }
  });
}

// Kernel sides are clamped just below the top level's size, so that level l + 1 always exists.
inline float max_side(int levels) { return shader::ot_max_side(levels); }

// A batch of square kernels cut to the texture, as box() and mean_over_squares() see them:
// kSquare: one square lookup (side, centre) times `fraction` (the kernel inside, or cut to a
// nearly square rectangle); kEmpty: 0 (entirely outside, or cut to an elongated rectangle
// that misses the slice's covered texels); kSlow: cut to an elongated rectangle that meets
// them, through box() (several lookups).
enum : int { kSquare = 0, kEmpty = 1, kSlow = 2 };
struct SquareBatch {
  float cx[kChunk], cy[kChunk], side[kChunk], fraction[kChunk];
  int mode[kChunk];
};
PENUMBRA_OT_CLONES void clip_squares(const float* __restrict X, const float* __restrict Y, const float* __restrict Q, size_t m, float W,
                  float H, const SliceBounds& bounds, SquareBatch& sq) {
  for (size_t i = 0; i < m; ++i) {
    const float half = 0.5f * std::max(Q[i], 1.0f);
    const float ux0 = X[i] - half, ux1 = X[i] + half, uy0 = Y[i] - half, uy1 = Y[i] + half;
    const float x0 = std::max(ux0, 0.0f), x1 = std::min(ux1, W), y0 = std::max(uy0, 0.0f), y1 = std::min(uy1, H);
    const float sx = x1 - x0, sy = y1 - y0;
    const float area = (ux1 - ux0) * (uy1 - uy0);
    const bool nonempty = (sx > 0) & (sy > 0);
    const bool squareish = (sx <= 1.25f * sy) & (sy <= 1.25f * sx);
    sq.cx[i] = 0.5f * (x0 + x1);
    sq.cy[i] = 0.5f * (y0 + y1);
    sq.side[i] = sx == sy ? sx : std::sqrt(std::max(sx * sy, 0.0f));
    sq.fraction[i] = nonempty ? sx * sy / area : 0.0f;
    // An elongated cut that misses every covered texel is 0 here already (as in box()).
    const int in = nonempty, square = squareish;
    const int meets = (ux0 < bounds.x1) & (ux1 > bounds.x0) & (uy0 < bounds.y1) & (uy1 > bounds.y0);
    const int strip = in & (square ^ 1);  // (bit operations: the loop stays vectorised)
    sq.mode[i] = (in ^ 1) | (strip & (meets ^ 1)) | ((strip & meets) << 1);  // kEmpty 1, kSlow 2, kSquare 0
  }
}
// Lookup counts, and the elongated rectangles through `box` (which counts itself).
template <class Box>
void finish_squares(const SquareBatch& sq, size_t m, const float* X, const float* Y, const float* Q, float* out,
                    LookupCounters& n, Box&& box) {
  for (size_t i = 0; i < m; ++i) {
    if (sq.mode[i] != kSlow) {
      ++n.lookups;
      n.outside += sq.mode[i] == kEmpty;
      continue;
    }
    ++n.strips;
    const float half = 0.5f * std::max(Q[i], 1.0f);
    out[i] = box(X[i] - half, Y[i] - half, X[i] + half, Y[i] + half);
  }
}

// A pyramid's square lookup (MipmapFilter::trilinear, NBufferFilter::square): occlusion_shared.h
// ot_square (both devices').
float shared_square(const shader::OtTextures& t, int k, float cx, float cy, float side, LookupCounters& n) {
  shader::OtCounters c{};
  const float v = shader::ot_square(t, k, cx, cy, side, c);
  n.reads += c.reads;
  return v;
}

// box() of any filter: occlusion_shared.h ot_box (both devices').
float shared_box(const shader::OtTextures& t, const SliceBounds& b, int k, float x0, float y0, float x1, float y1,
                 LookupCounters& n) {
  shader::OtCounters c{};
  const float v = shader::ot_box(t, shader::OtSliceBounds{b.x0, b.y0, b.x1, b.y1}, k, x0, y0, x1, y1, c);
  n.lookups += c.lookups;
  n.reads += c.reads;
  return v;
}

}  // namespace

std::vector<SliceBounds> coverage_bounds(const CoverageStack& c) {
  // OR of the masks along each row and each column: bit k of rows[y] = slice k covers
  // something in row y.
  std::vector<uint32_t> rows(c.height, 0), columns(c.width, 0);
  for (int y = 0; y < c.height; ++y) {
    const uint32_t* __restrict m = c.masks.data() + static_cast<size_t>(y) * c.width;
    uint32_t* __restrict col = columns.data();
    uint32_t r = 0;
    for (int x = 0; x < c.width; ++x) {
      r |= m[x];
      col[x] |= m[x];
    }
    rows[y] = r;
  }
  std::vector<SliceBounds> bounds(c.slices);
  for (int k = 0; k < c.slices; ++k) {
    const uint32_t bit = 1u << k;
    int x0 = c.width, x1 = 0, y0 = c.height, y1 = 0;
    for (int x = 0; x < c.width; ++x)
      if (columns[x] & bit) x0 = std::min(x0, x), x1 = x + 1;
    for (int y = 0; y < c.height; ++y)
      if (rows[y] & bit) y0 = std::min(y0, y), y1 = y + 1;
    bounds[k] = {float(x0), float(y0), float(x1), float(y1)};
  }
  return bounds;
}

shader::OtTextures pyramid_textures(uint32_t prefilter, int width, int height, const BytePyramid& pyramid) {
  shader::OtTextures t{};
  t.prefilter = prefilter;
  t.width = width;
  t.height = height;
  t.slices = pyramid.slices();
  t.levels = pyramid.levels();
  t.bytes = pyramid.levels() > 0 ? pyramid.plane(0, 0).data : nullptr;
  return t;
}

namespace {
// The planes' bytes of the first `levels` level sizes, and the padding row after them.
struct PyramidLayout {
  size_t planes = 0, padding = 0;
  PyramidLayout(int levels, int slices, const std::vector<std::pair<int, int>>& sizes) {
    size_t widest = 0;
    for (int l = 0; l < levels; ++l) {
      planes += static_cast<size_t>(sizes[l].first) * sizes[l].second * slices;
      widest = std::max<size_t>(widest, sizes[l].first);
    }
    padding = widest + 2;
  }
};
}  // namespace

uint64_t BytePyramid::bytes(int slices, const std::vector<std::pair<int, int>>& sizes) {
  const int levels = static_cast<int>(sizes.size());
  const PyramidLayout layout(levels, slices, sizes);
  return layout.planes + layout.padding + static_cast<uint64_t>(levels) * slices * sizeof(Plane);
}

void BytePyramid::allocate(int levels, int slices, const std::vector<std::pair<int, int>>& sizes) {
  levels_ = levels;
  slices_ = slices;
  const PyramidLayout layout(levels, slices, sizes);
  const size_t total = layout.planes;
  data_.resize(total + layout.padding);
  std::fill(data_.begin() + total, data_.end(), uint8_t{0});
  planes_.resize(static_cast<size_t>(levels) * slices);
  size_t offset = 0;
  for (int l = 0; l < levels; ++l)
    for (int k = 0; k < slices; ++k) {
      planes_[static_cast<size_t>(k) * levels + l] = {data_.data() + offset, sizes[l].first, sizes[l].second};
      offset += static_cast<size_t>(sizes[l].first) * sizes[l].second;
    }
}

// ----------------------------------------------------------------------------------------
// Mipmaps

std::vector<std::pair<int, int>> MipmapFilter::level_sizes(int width, int height) {
  const int levels = std::bit_width(static_cast<unsigned>(std::max(width, height)));
  std::vector<std::pair<int, int>> sizes;
  for (int l = 0; l < levels; ++l) sizes.emplace_back(level_side(width, l), level_side(height, l));
  return sizes;
}

void MipmapFilter::build(const CoverageStack& c) {
  width_ = c.width;
  height_ = c.height;
  bounds_ = coverage_bounds(c);
  const std::vector<std::pair<int, int>> sizes = level_sizes(c.width, c.height);
  const int levels = static_cast<int>(sizes.size());
  pyramid_.allocate(levels, c.slices, sizes);
  expand_bits(c, pyramid_);
  for (int l = 1; l < levels; ++l) {
    const int w = level_width(l), h = level_height(l), pw = level_width(l - 1), ph = level_height(l - 1);
    parallel_for(static_cast<size_t>(h) * c.slices, std::max(1, 8192 / w), [&](size_t r0, size_t r1) {
      for (size_t r = r0; r < r1; ++r) {
        const int k = static_cast<int>(r / h), j = static_cast<int>(r % h);
        const uint8_t* src = pyramid_.plane(l - 1, k).data;
        const uint8_t* ra = src + static_cast<size_t>(std::min(2 * j, ph - 1)) * pw;
        const uint8_t* rb = src + static_cast<size_t>(std::min(2 * j + 1, ph - 1)) * pw;
        uint8_t* o = pyramid_.mutable_plane(l, k) + static_cast<size_t>(j) * w;
        for (int i = 0; i < w; ++i) {
          const int xa = std::min(2 * i, pw - 1), xb = std::min(2 * i + 1, pw - 1);
          o[i] = mean4(ra[xa], ra[xb], rb[xa], rb[xb]);
        }
      }
    });
  }
}

float MipmapFilter::trilinear(int k, float cx, float cy, float side, LookupCounters& n) const {
  return shared_square(shared(), k, cx, cy, side, n);
}

shader::OtTextures MipmapFilter::shared() const {
  return pyramid_textures(shader::kOtMipmap, width_, height_, pyramid_);
}

float MipmapFilter::box(int k, float x0, float y0, float x1, float y1, LookupCounters& n) const {
  return shared_box(shared(), bounds_[k], k, x0, y0, x1, y1, n);
}

PENUMBRA_OT_CLONES void MipmapFilter::squares(int k, size_t count, const float* cx, const float* cy, const float* side, float* out,
                           LookupCounters& n) const {
  const float W = float(width_), H = float(height_), smax = max_side(levels());
  for (size_t b = 0; b < count; b += kChunk) {
    const size_t m = std::min(kChunk, count - b);
    SquareBatch sq;
    clip_squares(cx + b, cy + b, side + b, m, W, H, bounds_[k], sq);
    int level[kChunk], off0[kChunk], off1[kChunk];
    float f[kChunk], fx0[kChunk], fy0[kChunk], fx1[kChunk], fy1[kChunk];
    // Coordinates (the same arithmetic as trilinear(), over the batch).
    for (size_t i = 0; i < m; ++i) {
      const float s = std::min(std::max(sq.side[i], 1.0f), smax);
      const uint32_t bits = std::bit_cast<uint32_t>(s);
      const int l = static_cast<int>(bits >> 23) - 127;
      const float mant = std::bit_cast<float>((bits & 0x007fffffu) | 0x3f800000u) - 1.0f;
      level[i] = l;
      f[i] = mant * (1.3465f - 0.3465f * mant);
      const float scale0 = std::bit_cast<float>(static_cast<uint32_t>(127 - l) << 23), scale1 = 0.5f * scale0;
      const float w0 = std::max(1.0f, W * scale0), h0 = std::max(1.0f, H * scale0);
      const float w1 = std::max(1.0f, W * scale1), h1 = std::max(1.0f, H * scale1);
      const float x0 = std::min(std::max(sq.cx[i] * scale0 - 0.5f, 0.0f), w0 - 1.0f);
      const float y0 = std::min(std::max(sq.cy[i] * scale0 - 0.5f, 0.0f), h0 - 1.0f);
      const float x1 = std::min(std::max(sq.cx[i] * scale1 - 0.5f, 0.0f), w1 - 1.0f);
      const float y1 = std::min(std::max(sq.cy[i] * scale1 - 0.5f, 0.0f), h1 - 1.0f);
      const float ix0 = float(static_cast<int>(x0)), iy0 = float(static_cast<int>(y0));
      const float ix1 = float(static_cast<int>(x1)), iy1 = float(static_cast<int>(y1));
      fx0[i] = x0 - ix0;
      fy0[i] = y0 - iy0;
      fx1[i] = x1 - ix1;
      fy1[i] = y1 - iy1;
      off0[i] = static_cast<int>(iy0 * w0 + ix0);
      off1[i] = static_cast<int>(iy1 * w1 + ix1);
    }
    uint32_t q0[kChunk], q1[kChunk];
    size_t reads = 0;
    const BytePyramid::Plane* planes = pyramid_.planes(k);
    for (size_t i = 0; i < m; ++i) {
      const BytePyramid::Plane* p = planes + level[i];
      q0[i] = BytePyramid::quad(p[0].data + off0[i], p[0].w);
      q1[i] = BytePyramid::quad(p[1].data + off1[i], p[1].w);
      reads += sq.mode[i] == kSquare;
    }
    n.reads += 8 * reads;
    float* __restrict o = out + b;
    for (size_t i = 0; i < m; ++i) {
      const float a0 = float(q0[i] & 0xffu), b0 = float((q0[i] >> 8) & 0xffu);
      const float c0 = float((q0[i] >> 16) & 0xffu), d0 = float(q0[i] >> 24);
      const float a1 = float(q1[i] & 0xffu), b1 = float((q1[i] >> 8) & 0xffu);
      const float c1 = float((q1[i] >> 16) & 0xffu), d1 = float(q1[i] >> 24);
      const float top0 = a0 + (b0 - a0) * fx0[i], bottom0 = c0 + (d0 - c0) * fx0[i];
      const float top1 = a1 + (b1 - a1) * fx1[i], bottom1 = c1 + (d1 - c1) * fx1[i];
      const float v0 = (top0 + (bottom0 - top0) * fy0[i]) * (1.0f / 255.0f);
      const float v1 = (top1 + (bottom1 - top1) * fy1[i]) * (1.0f / 255.0f);
      o[i] = sq.mode[i] == kSquare ? sq.fraction[i] * (v0 + (v1 - v0) * f[i]) : 0.0f;
    }
    finish_squares(sq, m, cx + b, cy + b, side + b, o, n, [&](float x0, float y0, float x1, float y1) {
      return box(k, x0, y0, x1, y1, n);
    });
  }
}

// ----------------------------------------------------------------------------------------
// N-buffers

std::vector<std::pair<int, int>> NBufferFilter::level_sizes(int width, int height) {
  const int levels = std::bit_width(static_cast<unsigned>(std::min(width, height)));
  std::vector<std::pair<int, int>> sizes;
  for (int l = 0; l < levels; ++l) sizes.emplace_back(level_side(width, l), level_side(height, l));
  return sizes;
}

void NBufferFilter::build(const CoverageStack& c) {
  width_ = c.width;
  height_ = c.height;
  bounds_ = coverage_bounds(c);
  const std::vector<std::pair<int, int>> sizes = level_sizes(c.width, c.height);
  const int levels = static_cast<int>(sizes.size());
  pyramid_.allocate(levels, c.slices, sizes);
  expand_bits(c, pyramid_);
  // Level l+1 at anchor (x, y) = the mean of level l at (x, y), (x + n, y), (x, y + n),
  // (x + n, y + n) with n = 2^l: four lookups per texel (eisemann2006 §3.2).
  for (int l = 0; l + 1 < levels; ++l) {
    const size_t n = size_t{1} << l;
    const int w = level_width(l + 1), h = level_height(l + 1), pw = level_width(l);
    parallel_for(static_cast<size_t>(h) * c.slices, std::max(1, 16384 / w), [&](size_t r0, size_t r1) {
      for (size_t r = r0; r < r1; ++r) {
        const int k = static_cast<int>(r / h);
        const size_t j = r % h;
        const uint8_t* src = pyramid_.plane(l, k).data;
        mean4_row(src + j * pw, src + (j + n) * pw, n, pyramid_.mutable_plane(l + 1, k) + j * w, w);
      }
    });
  }
}

float NBufferFilter::square(int k, float cx, float cy, float side, LookupCounters& n) const {
  return shared_square(shared(), k, cx, cy, side, n);
}

shader::OtTextures NBufferFilter::shared() const {
  return pyramid_textures(shader::kOtNBuffer, width_, height_, pyramid_);
}

float NBufferFilter::box(int k, float x0, float y0, float x1, float y1, LookupCounters& n) const {
  return shared_box(shared(), bounds_[k], k, x0, y0, x1, y1, n);
}

PENUMBRA_OT_CLONES void NBufferFilter::squares(int k, size_t count, const float* cx, const float* cy, const float* side, float* out,
                            LookupCounters& n) const {
  const float W = float(width_), H = float(height_), smax = max_side(levels());
  for (size_t b = 0; b < count; b += kChunk) {
    const size_t m = std::min(kChunk, count - b);
    SquareBatch sq;
    clip_squares(cx + b, cy + b, side + b, m, W, H, bounds_[k], sq);
    int level[kChunk], off0[kChunk], off1[kChunk];
    float f[kChunk], fx0[kChunk], fy0[kChunk], fx1[kChunk], fy1[kChunk];
    // Coordinates (the same arithmetic as square(), over the batch).
    for (size_t i = 0; i < m; ++i) {
      const float s = std::min(std::max(sq.side[i], 1.0f), smax);
      const uint32_t bits = std::bit_cast<uint32_t>(s);
      const int l = static_cast<int>(bits >> 23) - 127;
      level[i] = l;
      f[i] = s * std::bit_cast<float>(static_cast<uint32_t>(127 - l) << 23) - 1.0f;
      const float size0 = std::bit_cast<float>(static_cast<uint32_t>(127 + l) << 23), size1 = 2.0f * size0;
      const float x0 = std::min(std::max(sq.cx[i] - 0.5f * size0, 0.0f), W - size0);
      const float y0 = std::min(std::max(sq.cy[i] - 0.5f * size0, 0.0f), H - size0);
      const float x1 = std::min(std::max(sq.cx[i] - 0.5f * size1, 0.0f), W - size1);
      const float y1 = std::min(std::max(sq.cy[i] - 0.5f * size1, 0.0f), H - size1);
      const float ix0 = float(static_cast<int>(x0)), iy0 = float(static_cast<int>(y0));
      const float ix1 = float(static_cast<int>(x1)), iy1 = float(static_cast<int>(y1));
      fx0[i] = x0 - ix0;
      fy0[i] = y0 - iy0;
      fx1[i] = x1 - ix1;
      fy1[i] = y1 - iy1;
      off0[i] = static_cast<int>(iy0 * (W + 1.0f - size0) + ix0);
      off1[i] = static_cast<int>(iy1 * (W + 1.0f - size1) + ix1);
    }
    // Texel reads (offsets are inside the planes whatever the mode).
    uint32_t q0[kChunk], q1[kChunk];
    size_t reads = 0;
    const BytePyramid::Plane* planes = pyramid_.planes(k);
    for (size_t i = 0; i < m; ++i) {
      const BytePyramid::Plane* p = planes + level[i];
      q0[i] = BytePyramid::quad(p[0].data + off0[i], p[0].w);
      q1[i] = BytePyramid::quad(p[1].data + off1[i], p[1].w);
      reads += sq.mode[i] == kSquare;
    }
    n.reads += 8 * reads;
    // Blends, over the batch (the same arithmetic as BytePyramid::bilinear and square()).
    float* __restrict o = out + b;
    for (size_t i = 0; i < m; ++i) {
      const float a0 = float(q0[i] & 0xffu), b0 = float((q0[i] >> 8) & 0xffu);
      const float c0 = float((q0[i] >> 16) & 0xffu), d0 = float(q0[i] >> 24);
      const float a1 = float(q1[i] & 0xffu), b1 = float((q1[i] >> 8) & 0xffu);
      const float c1 = float((q1[i] >> 16) & 0xffu), d1 = float(q1[i] >> 24);
      const float top0 = a0 + (b0 - a0) * fx0[i], bottom0 = c0 + (d0 - c0) * fx0[i];
      const float top1 = a1 + (b1 - a1) * fx1[i], bottom1 = c1 + (d1 - c1) * fx1[i];
      const float v0 = (top0 + (bottom0 - top0) * fy0[i]) * (1.0f / 255.0f);
      const float v1 = (top1 + (bottom1 - top1) * fy1[i]) * (1.0f / 255.0f);
      o[i] = sq.mode[i] == kSquare ? sq.fraction[i] * (v0 + (v1 - v0) * f[i]) : 0.0f;
    }
    finish_squares(sq, m, cx + b, cy + b, side + b, o, n, [&](float x0, float y0, float x1, float y1) {
      return box(k, x0, y0, x1, y1, n);
    });
  }
}

// ----------------------------------------------------------------------------------------
// Summed-area tables

template <class T>
void SatFilter<T>::build(const CoverageStack& c) {
  width_ = c.width;
  height_ = c.height;
  stride_ = static_cast<size_t>(c.width) + 1;
  slice_size_ = stride_ * (static_cast<size_t>(c.height) + 1);
  data_.resize(slice_size_ * c.slices);
  // One slice per task: row y + 1 = row y + the running count along row y.
  parallel_for(c.slices, 1, [&](size_t k0, size_t k1) {
    for (size_t k = k0; k < k1; ++k) {
      T* t = data_.data() + k * slice_size_;
      std::fill(t, t + stride_, T(0));
      const int width = c.width, height = c.height;
      const size_t stride = stride_;
      for (int y = 0; y < height; ++y) {
        const uint32_t* __restrict m = c.masks.data() + static_cast<size_t>(y) * width;
        const T* __restrict above = t + static_cast<size_t>(y) * stride;
        T* __restrict row = t + static_cast<size_t>(y + 1) * stride;
        row[0] = 0;
        uint32_t run = 0;
        for (int x = 0; x < width; ++x) {
          run += (m[x] >> k) & 1u;
          row[x + 1] = above[x + 1] + T(run);
        }
      }
    }
  });
}

namespace {

// Covered area in [x0, x1] x [y0, y1] (inside the texture) from the table: the box integral
// of raster/filtered_map.h (shared with the filtered-moment shadow maps), in float.
template <class E>
float sat_area_from(const E& e, float fx0, float fy0, float fx1, float fy1) {
  return sat_box_integral<float>(e, fx0, fy0, fx1, fy1);
}

}  // namespace

// occlusion_shared.h ot_box (both devices'; no slice bounds: the tables are exact).
template <class T>
float SatFilter<T>::box(int k, float x0, float y0, float x1, float y1, LookupCounters& n) const {
  return shared_box(shared(), SliceBounds{}, k, x0, y0, x1, y1, n);
}

template <class T>
shader::OtTextures SatFilter<T>::shared() const {
  shader::OtTextures t{};
  t.prefilter = shader::kOtSat;
  t.sat_counts = std::is_same_v<T, uint32_t> ? 1u : 0u;
  t.width = width_;
  t.height = height_;
  t.slices = static_cast<int>(slice_size_ == 0 ? 0 : data_.size() / slice_size_);
  if constexpr (std::is_same_v<T, uint32_t>) t.sat_u = data_.data();
  else t.sat_d = data_.data();
  const uint32_t stride = static_cast<uint32_t>(stride_);
  t.sat = {width_, height_, t.slices, 1u, stride, static_cast<uint32_t>(slice_size_)};
  return t;
}

// (Not multiversioned: the AVX2 clone measured 2x slower, its helpers not inlined.)
template <class T>
void SatFilter<T>::squares(int k, size_t count, const float* cx, const float* cy, const float* side, float* out,
                           LookupCounters& n) const {
  const T* t = data_.data() + static_cast<size_t>(k) * slice_size_;
  const float W = float(width_), H = float(height_), S = float(stride_);
  const size_t stride = stride_;
  for (size_t b = 0; b < count; b += kChunk) {
    const size_t m = std::min(kChunk, count - b);
    const float* __restrict X = cx + b;
    const float* __restrict Y = cy + b;
    const float* __restrict Q = side + b;
    int corner[4][kChunk];
    float fx0[kChunk], fx1[kChunk], fy0[kChunk], fy1[kChunk], inv_area[kChunk];
    // Corners cut to the texture (the same arithmetic as box() and sat_area()).
    for (size_t i = 0; i < m; ++i) {
      const float half = 0.5f * std::max(Q[i], 1.0f);
      const float ux0 = X[i] - half, ux1 = X[i] + half, uy0 = Y[i] - half, uy1 = Y[i] + half;
      const float x0 = std::max(ux0, 0.0f), x1 = std::min(ux1, W), y0 = std::max(uy0, 0.0f), y1 = std::min(uy1, H);
      const bool nonempty = (x1 > x0) & (y1 > y0);
      inv_area[i] = nonempty ? 1.0f / ((ux1 - ux0) * (uy1 - uy0)) : 0.0f;
      // Empty kernels read a valid corner with weight 0.
      const float cx0 = std::min(x0, W), cx1 = std::min(std::max(x1, 0.0f), W);
      const float cy0 = std::min(y0, H), cy1 = std::min(std::max(y1, 0.0f), H);
      const float i0 = std::min(float(static_cast<int>(cx0)), W - 1.0f), i1 = std::min(float(static_cast<int>(cx1)), W - 1.0f);
      const float j0 = std::min(float(static_cast<int>(cy0)), H - 1.0f), j1 = std::min(float(static_cast<int>(cy1)), H - 1.0f);
      fx0[i] = cx0 - i0;
      fx1[i] = cx1 - i1;
      fy0[i] = cy0 - j0;
      fy1[i] = cy1 - j1;
      corner[0][i] = static_cast<int>(j0 * S + i0);
      corner[1][i] = static_cast<int>(j0 * S + i1);
      corner[2][i] = static_cast<int>(j1 * S + i0);
      corner[3][i] = static_cast<int>(j1 * S + i1);
    }
    // Table reads: for each corner, the entry and its right, lower and lower-right neighbours
    // (for 32-bit counts, each horizontal pair in one 64-bit read).
    float* __restrict o = out + b;
    uint64_t reads = 0;
    if constexpr (std::is_same_v<T, uint32_t>) {
      uint64_t pair[8][kChunk];
      for (size_t i = 0; i < m; ++i)
        for (int c = 0; c < 4; ++c) {
          const T* p = t + corner[c][i];
          std::memcpy(&pair[2 * c][i], p, 8);
          std::memcpy(&pair[2 * c + 1][i], p + stride, 8);
        }
      for (size_t i = 0; i < m; ++i) {
        auto e = [&](int c, int k) { return static_cast<uint32_t>(pair[2 * c + (k >> 1)][i] >> (32 * (k & 1))); };
        o[i] = sat_area_from(e, fx0[i], fy0[i], fx1[i], fy1[i]) * inv_area[i];
        reads += inv_area[i] > 0;
      }
    } else {
      T e[16][kChunk];
      for (size_t i = 0; i < m; ++i)
        for (int c = 0; c < 4; ++c) {
          const T* p = t + corner[c][i];
          e[4 * c][i] = p[0];
          e[4 * c + 1][i] = p[1];
          e[4 * c + 2][i] = p[stride];
          e[4 * c + 3][i] = p[stride + 1];
        }
      for (size_t i = 0; i < m; ++i) {
        o[i] = sat_area_from([&](int c, int k) { return e[4 * c + k][i]; }, fx0[i], fy0[i], fx1[i], fy1[i]) * inv_area[i];
        reads += inv_area[i] > 0;
      }
    }
    n.lookups += m;
    n.reads += 16 * reads;
    n.outside += m - reads;
  }
}

template class SatFilter<uint32_t>;
template class SatFilter<double>;

}  // namespace penumbra::occlusion
