// The prefiltered maps' lookups once for both devices (raster/filtered_map.h states what they
// mean), in the common subset of C++ and GLSL (core/shader_compat.h, shader_compat_math.h): the
// box integral of a summed-area table (Crow 1984) in the three kinds penumbra keeps (uint32
// counts or doubles, summed in float or double), a multi-channel double table's box mean, and
// the float mip chain's bilinear taps and tap-grid box mean. SummedAreaTable, MipChain and the
// occlusion textures' SatFilter (shadow/occlusion_textures/prefilter.h) call these functions; the
// GPU's tables (gpu/filtered/gpu_filtered_map.h) have the same layouts, so a GPU lookup reads
// what the CPU's would and sums it in the same order.
//
// Layouts (also the GPU buffers'):
// - a summed-area table of a width x height map with C channels: (width + 1) x (height + 1)
//   entries per channel, entry (x, y) = the sum over [0, x) x [0, y); channel c of entry (x, y)
//   at c * channel_stride + y * row_stride + x * x_stride (SummedAreaTable: channels
//   interleaved, x_stride = C, channel_stride = 1, row_stride = (width + 1) C; SatFilter: one
//   plane per slice, x_stride = 1, row_stride = width + 1, channel_stride = the plane's size);
// - a mip chain: level 0 the map padded to a side x side power-of-two square, then each level
//   half the side, one after another in one array, each row-major with C channels interleaved
//   (level l's texel (x, y) channel c at mip_level_offset(side, C, l) + ((y side_l + x) C + c)).
#ifndef PENUMBRA_RASTER_FILTERED_MAP_SHARED_H
#define PENUMBRA_RASTER_FILTERED_MAP_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/core/shader_compat_math.h"

PN_SHARED_BEGIN

PN_CONST int kFilteredMaxChannels = 4;

// Up to four channels' values.
struct FilteredChannels {
  double v[4];
};

// The 16 table entries a box reads: e[4 c + k] = T at (i, j), (i+1, j), (i, j+1), (i+1, j+1)
// (k = 0..3) of corner c = (x0, y0), (x1, y0), (x0, y1), (x1, y1) (c = 0..3), (i, j) the
// corner's texel.
struct SatCornersU {
  uint e[16];
};
struct SatCornersD {
  double e[16];
};

// The integral over [x0, x1] x [y0, y1] of a map whose summed-area table gave the corners q
// (filtered_map.h sat_box_integral): the integral image is bilinear in each texel,
// F(i + fx, j + fy) = T(i, j) + fx Dx + fy Dy + fx fy c. Summed over the four corners with their
// signs, the T terms make an exact count (for integer tables), and the Dx (Dy) terms of two
// corners sharing a fraction differ by a sum along one column (row) of the box: every number
// multiplied by a fraction is small, so nothing large cancels. (fx0, fy0), (fx1, fy1): the
// corners' fractions within their texels. DIFF(a, b) is the difference of two entries in the
// accumulator type: exact in int32 for counts (wrapping arithmetic gives the true difference,
// which is small).
#define PN_SAT_BOX_INTEGRAL(NAME, CORNERS, ENTRY, ACC, DIFF)                                             \
  PN_INLINE ACC NAME(CORNERS q, ACC fx0, ACC fy0, ACC fx1, ACC fy1) {                                    \
    ACC count = DIFF(q.e[12], q.e[8]) - DIFF(q.e[4], q.e[0]);                                            \
    ENTRY dx0 = q.e[1] - q.e[0];                                                                         \
    ENTRY dx1 = q.e[5] - q.e[4];                                                                         \
    ENTRY dx2 = q.e[9] - q.e[8];                                                                         \
    ENTRY dx3 = q.e[13] - q.e[12];                                                                       \
    ENTRY dy0 = q.e[2] - q.e[0];                                                                         \
    ENTRY dy1 = q.e[6] - q.e[4];                                                                         \
    ENTRY dy2 = q.e[10] - q.e[8];                                                                        \
    ENTRY dy3 = q.e[14] - q.e[12];                                                                       \
    ACC x1 = DIFF(dx3, dx1);                                                                             \
    ACC x0 = DIFF(dx2, dx0);                                                                             \
    ACC y1 = DIFF(dy3, dy2);                                                                             \
    ACC y0 = DIFF(dy1, dy0);                                                                             \
    ACC t0 = DIFF(q.e[3] - q.e[2], dx0);                                                                 \
    ACC t1 = DIFF(q.e[7] - q.e[6], dx1);                                                                 \
    ACC t2 = DIFF(q.e[11] - q.e[10], dx2);                                                               \
    ACC t3 = DIFF(q.e[15] - q.e[14], dx3);                                                               \
    PN_PRECISE ACC r = count + (fx1 * x1 - fx0 * x0) + (fy1 * y1 - fy0 * y0) +                           \
                       (fx1 * fy1 * t3 - fx0 * fy1 * t2 - fx1 * fy0 * t1 + fx0 * fy0 * t0);              \
    return r;                                                                                            \
  }
#define PN_SAT_DIFF_COUNT(a, b) float(int((a) - (b)))
#define PN_SAT_DIFF_DOUBLE_FLOAT(a, b) float((a) - (b))
#define PN_SAT_DIFF_DOUBLE(a, b) ((a) - (b))
// uint32 counts summed in float (occlusion textures' default tables), double tables summed in
// float (their sat_precision=double) and in double (the moments' tables).
PN_SAT_BOX_INTEGRAL(sat_box_integral_uf, SatCornersU, uint, float, PN_SAT_DIFF_COUNT)
PN_SAT_BOX_INTEGRAL(sat_box_integral_df, SatCornersD, double, float, PN_SAT_DIFF_DOUBLE_FLOAT)
PN_SAT_BOX_INTEGRAL(sat_box_integral_dd, SatCornersD, double, double, PN_SAT_DIFF_DOUBLE)
#undef PN_SAT_BOX_INTEGRAL

// Where a table's entries are (see the layouts above).
struct SatTableLayout {
  int width;  // the map's, in texels (the table has width + 1 columns)
  int height;
  int channels;
  uint x_stride;
  uint row_stride;
  uint channel_stride;
};

// The 16 entries of channel c a box with corner texels (i0, j0) and (i1, j1) reads.
#define PN_SAT_CORNERS(NAME, CORNERS, ARRAY)                                                       \
  PN_INLINE CORNERS NAME(ARRAY t, SatTableLayout l, int c, int i0, int j0, int i1, int j1) {        \
    CORNERS q;                                                                                     \
    int is[4] = {i0, i1, i0, i1};                                                                  \
    int js[4] = {j0, j0, j1, j1};                                                                  \
    for (int k = 0; k < 4; ++k) {                                                                  \
      uint base = uint(c) * l.channel_stride + uint(js[k]) * l.row_stride + uint(is[k]) * l.x_stride; \
      q.e[4 * k] = PN_AT(t, base);                                                                 \
      q.e[4 * k + 1] = PN_AT(t, base + l.x_stride);                                               \
      q.e[4 * k + 2] = PN_AT(t, base + l.row_stride);                                              \
      q.e[4 * k + 3] = PN_AT(t, base + l.row_stride + l.x_stride);                                 \
    }                                                                                              \
    return q;                                                                                      \
  }
PN_SAT_CORNERS(sat_corners_d, SatCornersD, PN_DOUBLE_ARRAY)
PN_SAT_CORNERS(sat_corners_u, SatCornersU, PN_UINT_ARRAY)
#undef PN_SAT_CORNERS

// SummedAreaTable::box_mean: the mean of every channel over [x0, x1] x [y0, y1] (x0 <= x1,
// y0 <= y1; a rectangle of zero area reads as its point's texel); outside the map every channel
// holds `outside`.
PN_INLINE FilteredChannels sat_box_mean(PN_DOUBLE_ARRAY t, SatTableLayout l, FilteredChannels outside, double x0,
                                        double y0, double x1, double y1) {
  double area = (x1 - x0) * (y1 - y0);
  if (!(area > double(0.0f))) {  // a point: its texel (or outside)
    x0 = pn_dfloor(x0);
    y0 = pn_dfloor(y0);
    x1 = x0 + double(1.0f);
    y1 = y0 + double(1.0f);
    area = (x1 - x0) * (y1 - y0);
  }
  double cx0 = pn_dmax(x0, double(0.0f));
  double cy0 = pn_dmax(y0, double(0.0f));
  double cx1 = pn_dmin(x1, double(l.width));
  double cy1 = pn_dmin(y1, double(l.height));
  double inside = cx1 > cx0 && cy1 > cy0 ? (cx1 - cx0) * (cy1 - cy0) : double(0.0f);
  FilteredChannels res;
  // The part outside the map holds the outside values.
  for (int c = 0; c < kFilteredMaxChannels; ++c) res.v[c] = c < l.channels ? outside.v[c] * (area - inside) / area : double(0.0f);
  if (inside == double(0.0f)) return res;
  int i0 = min(int(cx0), l.width - 1);
  int i1 = min(int(cx1), l.width - 1);
  int j0 = min(int(cy0), l.height - 1);
  int j1 = min(int(cy1), l.height - 1);
  for (int c = 0; c < l.channels; ++c) {
    double integral = sat_box_integral_dd(sat_corners_d(t, l, c, i0, j0, i1, j1), cx0 - double(i0), cy0 - double(j0),
                                          cx1 - double(i1), cy1 - double(j1));
    res.v[c] += integral / area;
  }
  return res;
}

// A mip chain as the lookups read it (see the layouts above).
struct MipChainView {
  int side;  // level 0's side, a power of two
  int levels;
  int channels;
  int pad;
  float outside[4];
};

// Where level l starts: the texels of the levels before it.
PN_INLINE uint mip_level_offset(int side, int channels, int level) {
  uint offset = 0u;
  for (int l = 0; l < level; ++l) offset += uint(side >> l) * uint(side >> l) * uint(channels);
  return offset;
}

// MipChain::bilinear: level `level` at texel-space point (x, y) of level 0, texel centres at
// (i + 0.5) in level units, texels beyond the level holding the outside values.
PN_INLINE FilteredChannels mip_bilinear(PN_FLOAT_ARRAY texels, MipChainView m, int level, float x, float y) {
  int side = m.side >> level;
  uint base = mip_level_offset(m.side, m.channels, level);
  float scale = 1.0f / float(1 << level);
  PN_PRECISE float u = x * scale - 0.5f;
  PN_PRECISE float v = y * scale - 0.5f;
  int i = int(floor(u));
  int j = int(floor(v));
  float fx = u - float(i);
  float fy = v - float(j);
  float w[4] = {(1.0f - fx) * (1.0f - fy), fx * (1.0f - fy), (1.0f - fx) * fy, fx * fy};
  int xs[4] = {i, i + 1, i, i + 1};
  int ys[4] = {j, j, j + 1, j + 1};
  FilteredChannels res;
  for (int c = 0; c < kFilteredMaxChannels; ++c) res.v[c] = double(0.0f);
  for (int k = 0; k < 4; ++k) {
    bool inside = xs[k] >= 0 && ys[k] >= 0 && xs[k] < side && ys[k] < side;
    uint at = base + (uint(ys[k]) * uint(side) + uint(xs[k])) * uint(m.channels);
    for (int c = 0; c < m.channels; ++c) {
      float t = inside ? PN_AT(texels, at + uint(c)) : m.outside[c];
      res.v[c] += double(w[k]) * double(t);
    }
  }
  return res;
}

// MipChain::box_mean: every channel's mean over [x0, x1] x [y0, y1], at the two levels around
// the level of detail log2(longer side / 4) the mean of a grid of bilinear taps one texel of
// that level apart (4 to 8 along the longer side), blended by the fractional level (as a GPU's
// trilinear filter). The level of detail is log2 in float: on the GPU a few ulps from libm's.
PN_INLINE FilteredChannels mip_box_mean(PN_FLOAT_ARRAY texels, MipChainView m, float x0, float y0, float x1, float y1) {
  int taps = 4;
  float sx = max(x1 - x0, 0.0f);
  float sy = max(y1 - y0, 0.0f);
  float longer = max(max(sx, sy), 1.0f);
  float lod = clamp(pn_log2f(longer / float(taps)), 0.0f, float(m.levels - 1));
  int l0 = int(lod);
  int l1 = min(l0 + 1, m.levels - 1);
  float f = lod - float(l0);
  bool blend = f > 0.0f && l1 != l0;
  FilteredChannels at[2];
  for (int k = 0; k < (blend ? 2 : 1); ++k) {
    int level = k == 0 ? l0 : l1;
    float cell = float(1 << level);
    int nx = min(max(int(pn_ceilf(sx / cell)), 1), 2 * taps);
    int ny = min(max(int(pn_ceilf(sy / cell)), 1), 2 * taps);
    for (int c = 0; c < kFilteredMaxChannels; ++c) at[k].v[c] = double(0.0f);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        FilteredChannels tap = mip_bilinear(texels, m, level, x0 + sx * (float(i) + 0.5f) / float(nx),
                                            y0 + sy * (float(j) + 0.5f) / float(ny));
        for (int c = 0; c < m.channels; ++c) at[k].v[c] += tap.v[c];
      }
    for (int c = 0; c < m.channels; ++c) at[k].v[c] /= double(nx * ny);
  }
  if (!blend) return at[0];
  FilteredChannels res;
  for (int c = 0; c < kFilteredMaxChannels; ++c) {
    PN_PRECISE double blended = at[0].v[c] + (at[1].v[c] - at[0].v[c]) * double(f);
    res.v[c] = blended;
  }
  return res;
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::SatTableLayout) == 24);
static_assert(sizeof(penumbra::shader::MipChainView) == 32);
#endif

#endif  // PENUMBRA_RASTER_FILTERED_MAP_SHARED_H
