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

// The rectangle [x0, x1] x [y0, y1] cut to the texture; `fraction` = the share of the
// rectangle's area inside (0 if none).
struct ClippedRect {
  float x0, y0, x1, y1;
  float fraction;
};
ClippedRect clip_rect(float x0, float y0, float x1, float y1, int width, int height) {
  const float area = (x1 - x0) * (y1 - y0);
  ClippedRect r{std::max(x0, 0.0f), std::max(y0, 0.0f), std::min(x1, float(width)), std::min(y1, float(height)), 0};
  if (r.x1 > r.x0 && r.y1 > r.y0 && area > 0) r.fraction = (r.x1 - r.x0) * (r.y1 - r.y0) / area;
  return r;
}

// A rectangle as squares (the anisotropic filtering of a GPU): one square when it is square,
// one of the geometric-mean side when nearly so (sides within 25%), otherwise
// n = min(16, ceil(long / short)) squares of side max(short, long / 16) spread evenly along
// the long side. square(cx, cy, side) returns the filtered mean of one square.
template <class Square>
float mean_over_squares(const ClippedRect& r, Square&& square) {
  const float sx = r.x1 - r.x0, sy = r.y1 - r.y0;
  const float cx = 0.5f * (r.x0 + r.x1), cy = 0.5f * (r.y0 + r.y1);
  if (sx == sy) return square(cx, cy, sx);
  if (sx <= 1.25f * sy && sy <= 1.25f * sx) return square(cx, cy, std::sqrt(sx * sy));
  const bool wide = sx > sy;
  const float lo = wide ? r.x0 : r.y0, len = wide ? sx : sy, other = wide ? sy : sx;
  const int n = std::min(16, static_cast<int>(std::ceil(len / other)));
  const float side = std::max(other, len / 16.0f);
  const float step = n > 1 ? (len - side) / float(n - 1) : 0.0f;
  float sum = 0;
  for (int i = 0; i < n; ++i) {
    const float c = lo + 0.5f * side + step * float(i);
    sum += wide ? square(c, cy, side) : square(cx, c, side);
  }
  return sum / float(n);
}

// Whether the square of half-side h centred on (cx, cy) lies inside a w x h texture.
inline bool inside(float cx, float cy, float half, float width, float height) {
  return cx - half >= 0 && cy - half >= 0 && cx + half <= width && cy + half <= height;
}

// Kernel sides are clamped just below the top level's size, so that level l + 1 always exists.
inline float max_side(int levels) { return exp2_int(levels - 1) * (1.0f - 1.0f / 4096.0f); }

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

// box() of the 8-bit pyramids: cut to the texture; an elongated cut (more than 5:4) that
// misses every covered texel is 0 (the exact answer, without the several lookups).
template <class Square>
float pyramid_box(float x0, float y0, float x1, float y1, int width, int height, const SliceBounds& bounds,
                  Square&& square) {
  const ClippedRect r = clip_rect(x0, y0, x1, y1, width, height);
  if (r.fraction <= 0) return 0;
  const float sx = r.x1 - r.x0, sy = r.y1 - r.y0;
  if (!(sx <= 1.25f * sy && sy <= 1.25f * sx) && !bounds.meets(x0, y0, x1, y1)) return 0;
  return r.fraction * mean_over_squares(r, square);
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

// Level l = floor(lod), fraction f, lod = approx_log2(side): bilinear in levels l and l + 1
// at the kernel's centre, clamped to each level's edge texels.
float MipmapFilter::trilinear(int k, float cx, float cy, float side, LookupCounters& n) const {
  const float s = std::min(std::max(side, 1.0f), max_side(levels()));
  const uint32_t bits = std::bit_cast<uint32_t>(s);
  const int l = static_cast<int>(bits >> 23) - 127;
  const float m = std::bit_cast<float>((bits & 0x007fffffu) | 0x3f800000u) - 1.0f;
  const float f = m * (1.3465f - 0.3465f * m);
  float v[2];
  for (int i = 0; i < 2; ++i) {
    const float scale = exp2_int(-(l + i));
    const float w = std::max(1.0f, float(width_) * scale), h = std::max(1.0f, float(height_) * scale);
    const float x = std::min(std::max(cx * scale - 0.5f, 0.0f), w - 1.0f);
    const float y = std::min(std::max(cy * scale - 0.5f, 0.0f), h - 1.0f);
    const float ix = float(static_cast<int>(x)), iy = float(static_cast<int>(y));
    const BytePyramid::Plane& p = pyramid_.plane(l + i, k);
    v[i] = BytePyramid::bilinear(BytePyramid::quad(p.data + static_cast<int>(iy * w + ix), p.w), x - ix, y - iy);
  }
  n.reads += 8;
  return v[0] + (v[1] - v[0]) * f;
}

float MipmapFilter::box(int k, float x0, float y0, float x1, float y1, LookupCounters& n) const {
  ++n.lookups;
  return pyramid_box(x0, y0, x1, y1, width_, height_, bounds_[k],
                     [&](float cx, float cy, float side) { return trilinear(k, cx, cy, side, n); });
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

// The square of side q in [2^l, 2^(l+1)): f = q / 2^l - 1 between the 2^l and 2^(l+1) boxes
// centred on (cx, cy), each bilinear between its integer anchors (the box mean of a
// piecewise-constant texture is bilinear in the box's position), anchors clamped inside.
float NBufferFilter::square(int k, float cx, float cy, float side, LookupCounters& n) const {
  const float s = std::min(std::max(side, 1.0f), max_side(levels()));
  const int l = static_cast<int>(std::bit_cast<uint32_t>(s) >> 23) - 127;
  const float f = s * exp2_int(-l) - 1.0f;
  float v[2];
  for (int i = 0; i < 2; ++i) {
    const float size = exp2_int(l + i);
    const float x = std::min(std::max(cx - 0.5f * size, 0.0f), float(width_) - size);
    const float y = std::min(std::max(cy - 0.5f * size, 0.0f), float(height_) - size);
    const float ix = float(static_cast<int>(x)), iy = float(static_cast<int>(y));
    const BytePyramid::Plane& p = pyramid_.plane(l + i, k);
    v[i] = BytePyramid::bilinear(BytePyramid::quad(p.data + static_cast<int>(iy * (float(width_) + 1.0f - size) + ix), p.w),
                                 x - ix, y - iy);
  }
  n.reads += 8;
  return v[0] + (v[1] - v[0]) * f;
}

float NBufferFilter::box(int k, float x0, float y0, float x1, float y1, LookupCounters& n) const {
  ++n.lookups;
  return pyramid_box(x0, y0, x1, y1, width_, height_, bounds_[k],
                     [&](float cx, float cy, float side) { return square(k, cx, cy, side, n); });
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

template <class T>
float sat_area(const T* t, size_t stride, int width, int height, float x0, float y0, float x1, float y1) {
  const int i0 = std::min(static_cast<int>(x0), width - 1), i1 = std::min(static_cast<int>(x1), width - 1);
  const int j0 = std::min(static_cast<int>(y0), height - 1), j1 = std::min(static_cast<int>(y1), height - 1);
  const T* corner[4] = {t + static_cast<size_t>(j0) * stride + i0, t + static_cast<size_t>(j0) * stride + i1,
                        t + static_cast<size_t>(j1) * stride + i0, t + static_cast<size_t>(j1) * stride + i1};
  const size_t offset[4] = {0, 1, stride, stride + 1};
  return sat_area_from([&](int c, int k) { return corner[c][offset[k]]; }, x0 - float(i0), y0 - float(j0),
                       x1 - float(i1), y1 - float(j1));
}

}  // namespace

template <class T>
float SatFilter<T>::box(int k, float x0, float y0, float x1, float y1, LookupCounters& n) const {
  ++n.lookups;
  const float area = (x1 - x0) * (y1 - y0);
  const float cx0 = std::max(x0, 0.0f), cy0 = std::max(y0, 0.0f);
  const float cx1 = std::min(x1, float(width_)), cy1 = std::min(y1, float(height_));
  if (!(cx1 > cx0 && cy1 > cy0 && area > 0)) return 0;
  n.reads += 16;
  return sat_area(data_.data() + static_cast<size_t>(k) * slice_size_, stride_, width_, height_, cx0, cy0, cx1, cy1) *
         (1.0f / area);
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
