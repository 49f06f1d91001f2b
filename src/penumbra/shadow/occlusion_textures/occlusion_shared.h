// `occlusion-textures` (eisemann2006) per point and per lookup once for both devices
// (occlusion_textures.h and prefilter.h state the method), in the common subset of C++ and GLSL
// (core/shader_compat.h, shader_compat_math.h): a point's slices above it, its kernel on each
// slice's texture (eq. 4), the fade and the combination of eq. 5, and the box filters of §3.2
// over the prefiltered textures (trilinear mipmaps, N-buffers, summed-area tables). The CPU's
// OcclusionTextures and filters call these functions (its batched loops call the per-point
// ones); the GPU kernels (occlusion_textures/kernels/) include this header. Also the GPU's
// records, byte by byte.
//
// Textures are read through OtTextures. The 8-bit pyramids (mipmaps, N-buffers) hold one plane
// per (level, slice), level after level and slice after slice within a level, each row-major,
// then a padding row (prefilter.h BytePyramid): plane (l, k) starts at ot_plane_offset(l, k).
// Summed-area tables: one per slice (raster/filtered_map_shared.h's layout, SatFilter's).
#ifndef PENUMBRA_SHADOW_OCCLUSION_TEXTURES_OCCLUSION_SHARED_H
#define PENUMBRA_SHADOW_OCCLUSION_TEXTURES_OCCLUSION_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/core/shader_compat_math.h"
#include "penumbra/raster/filtered_map_shared.h"
#include "penumbra/shadow/light_horizon_shared.h"

PN_SHARED_BEGIN

PN_CONST uint kOtMipmap = 0u;
PN_CONST uint kOtNBuffer = 1u;
PN_CONST uint kOtSat = 2u;
PN_CONST uint kOtProduct = 0u;
PN_CONST uint kOtSum = 1u;
PN_CONST uint kOtMax = 2u;
PN_CONST int kOtMaxSlices = 32;

// 2^e for an integer e in the normal float range, from its exponent bits.
PN_INLINE float ot_exp2_int(int e) { return uintBitsToFloat(uint(e + 127) << 23); }

// Texel reads and lookups (prefilter.h LookupCounters, per point).
struct OtCounters {
  uint lookups;  // filtered lookups (one per kernel)
  uint reads;    // texels read
  uint outside;  // kernels entirely outside the texture (0, nothing read)
  uint strips;   // kernels cut by the border to an elongated rectangle (mipmap, N-buffer)
};

// The texels one slice covers, as a rectangle [x0, x1) x [y0, y1) (prefilter.h SliceBounds;
// empty: x0 >= x1).
struct OtSliceBounds {
  float x0;
  float y0;
  float x1;
  float y1;
};
PN_INLINE bool ot_bounds_meet(OtSliceBounds b, float ax0, float ay0, float ax1, float ay1) {
  return ax0 < b.x1 && ax1 > b.x0 && ay0 < b.y1 && ay1 > b.y0;
}

// The prefiltered textures as the lookups read them (built where used, never stored).
struct OtTextures {
  uint prefilter;  // kOt*
  uint sat_counts; // summed-area tables of uint32 counts (else doubles)
  int width;
  int height;
  int slices;
  int levels;     // the pyramid's
  PN_BYTE_ARRAY bytes;     // the pyramids
  PN_UINT_ARRAY sat_u;     // the summed-area tables
  PN_DOUBLE_ARRAY sat_d;
  SatTableLayout sat;
};

// A pyramid level's side (texels, or N-buffer anchors) for a texture side `side`.
PN_INLINE int ot_level_side(uint prefilter, int side, int l) {
  return prefilter == kOtMipmap ? max(1, side >> l) : side - (1 << l) + 1;
}
// Where plane (l, k) starts in the pyramid.
PN_INLINE uint ot_plane_offset(OtTextures t, int l, int k) {
  uint offset = 0u;
  for (int i = 0; i < l; ++i)
    offset += uint(ot_level_side(t.prefilter, t.width, i)) * uint(ot_level_side(t.prefilter, t.height, i)) * uint(t.slices);
  return offset + uint(k) * uint(ot_level_side(t.prefilter, t.width, l)) * uint(ot_level_side(t.prefilter, t.height, l));
}

// BytePyramid::quad and bilinear: the 2 x 2 bytes at `at` (row stride w), blended, in [0, 1].
PN_INLINE float ot_bilinear(PN_BYTE_ARRAY bytes, uint at, uint w, float fx, float fy) {
  float a = float(uint(PN_AT(bytes, at)));
  float b = float(uint(PN_AT(bytes, at + 1u)));
  float c = float(uint(PN_AT(bytes, at + w)));
  float d = float(uint(PN_AT(bytes, at + w + 1u)));
  PN_PRECISE float top = a + (b - a) * fx;
  PN_PRECISE float bottom = c + (d - c) * fx;
  PN_PRECISE float v = (top + (bottom - top) * fy) * (1.0f / 255.0f);
  return v;
}

// Kernel sides are clamped just below the top level's size, so that level l + 1 always exists.
PN_INLINE float ot_max_side(int levels) { return ot_exp2_int(levels - 1) * (1.0f - 1.0f / 4096.0f); }

// Level `level` of slice k read bilinearly at (x, y) in its texels (or anchors), clamped inside
// by the caller; `row` is the level's row width as the texel offset is computed from it.
PN_INLINE float ot_level_read(OtTextures t, int level, int k, float x, float y, float row) {
  float ix = float(int(x));
  float iy = float(int(y));
  PN_PRECISE float texel = iy * row + ix;
  uint at = ot_plane_offset(t, level, k) + uint(int(texel));
  return ot_bilinear(t.bytes, at, uint(ot_level_side(t.prefilter, t.width, level)), x - ix, y - iy);
}

// Two levels' values blended by the fraction f (8 texels read).
PN_INLINE float ot_blend_levels(float v0, float v1, float f, PN_INOUT(OtCounters) n) {
  n.reads += 8u;
  PN_PRECISE float r = v0 + (v1 - v0) * f;
  return r;
}

// MipmapFilter::trilinear: level l = floor(lod), fraction f, lod = log2(side) approximated by the
// exponent plus a quadratic in the mantissa (error < 0.006; as a GPU's level-of-detail computation);
// bilinear in levels l and l + 1 at the kernel's centre, clamped to each level's edge texels.
PN_INLINE float ot_trilinear(OtTextures t, int k, float cx, float cy, float side, PN_INOUT(OtCounters) n) {
  float s = min(max(side, 1.0f), ot_max_side(t.levels));
  uint bits = floatBitsToUint(s);
  int l = int(bits >> 23) - 127;
  float m = uintBitsToFloat((bits & 0x007fffffu) | 0x3f800000u) - 1.0f;
  PN_PRECISE float f = m * (1.3465f - 0.3465f * m);
  float v[2];
  for (int i = 0; i < 2; ++i) {
    float scale = ot_exp2_int(-(l + i));
    float w = max(1.0f, float(t.width) * scale);
    float h = max(1.0f, float(t.height) * scale);
    PN_PRECISE float xs = cx * scale - 0.5f;
    PN_PRECISE float ys = cy * scale - 0.5f;
    v[i] = ot_level_read(t, l + i, k, min(max(xs, 0.0f), w - 1.0f), min(max(ys, 0.0f), h - 1.0f), w);
  }
  return ot_blend_levels(v[0], v[1], f, n);
}

// NBufferFilter::square: a square of side q in [2^l, 2^(l+1)): f = q / 2^l - 1 between the 2^l
// and 2^(l+1) boxes centred on (cx, cy), each bilinear between its integer anchors (the box mean
// of a piecewise-constant texture is bilinear in the box's position), anchors clamped inside.
PN_INLINE float ot_nbuffer_square(OtTextures t, int k, float cx, float cy, float side, PN_INOUT(OtCounters) n) {
  float s = min(max(side, 1.0f), ot_max_side(t.levels));
  int l = int(floatBitsToUint(s) >> 23) - 127;
  PN_PRECISE float f = s * ot_exp2_int(-l) - 1.0f;
  float v[2];
  for (int i = 0; i < 2; ++i) {
    float size = ot_exp2_int(l + i);
    PN_PRECISE float xs = cx - 0.5f * size;
    PN_PRECISE float ys = cy - 0.5f * size;
    v[i] = ot_level_read(t, l + i, k, min(max(xs, 0.0f), float(t.width) - size),
                         min(max(ys, 0.0f), float(t.height) - size), float(t.width) + 1.0f - size);
  }
  return ot_blend_levels(v[0], v[1], f, n);
}

// One square lookup of the pyramid the textures have.
PN_INLINE float ot_square(OtTextures t, int k, float cx, float cy, float side, PN_INOUT(OtCounters) n) {
  if (t.prefilter == kOtMipmap) return ot_trilinear(t, k, cx, cy, side, n);
  return ot_nbuffer_square(t, k, cx, cy, side, n);
}

// A rectangle (cut to the texture) as squares (the anisotropic filtering of a GPU): one square
// when it is square, one of the geometric-mean side when nearly so (sides within 25%), otherwise
// n = min(16, ceil(long / short)) squares of side max(short, long / 16) spread evenly along the
// long side (prefilter.cpp mean_over_squares).
PN_INLINE float ot_mean_over_squares(OtTextures t, int k, float x0, float y0, float x1, float y1,
                                     PN_INOUT(OtCounters) n) {
  float sx = x1 - x0;
  float sy = y1 - y0;
  float cx = 0.5f * (x0 + x1);
  float cy = 0.5f * (y0 + y1);
  if (sx == sy) return ot_square(t, k, cx, cy, sx, n);
  if (sx <= 1.25f * sy && sy <= 1.25f * sx) return ot_square(t, k, cx, cy, sqrt(sx * sy), n);
  bool wide = sx > sy;
  float lo = wide ? x0 : y0;
  float len = wide ? sx : sy;
  float other = wide ? sy : sx;
  int count = min(16, int(pn_ceilf(len / other)));
  float side = max(other, len / 16.0f);
  float step = count > 1 ? (len - side) / float(count - 1) : 0.0f;
  float sum = 0.0f;
  for (int i = 0; i < count; ++i) {
    PN_PRECISE float c = lo + 0.5f * side + step * float(i);
    sum += wide ? ot_square(t, k, c, cy, side, n) : ot_square(t, k, cx, c, side, n);
  }
  return sum / float(count);
}

// The summed-area table's covered area in [x0, x1] x [y0, y1] (inside the texture; prefilter.cpp
// sat_area): the box integral of raster/filtered_map_shared.h, in float.
PN_INLINE float ot_sat_area(OtTextures t, int k, float x0, float y0, float x1, float y1) {
  int i0 = min(int(x0), t.width - 1);
  int i1 = min(int(x1), t.width - 1);
  int j0 = min(int(y0), t.height - 1);
  int j1 = min(int(y1), t.height - 1);
  float fx0 = x0 - float(i0);
  float fy0 = y0 - float(j0);
  float fx1 = x1 - float(i1);
  float fy1 = y1 - float(j1);
  if (t.sat_counts != 0u) return sat_box_integral_uf(sat_corners_u(t.sat_u, t.sat, k, i0, j0, i1, j1), fx0, fy0, fx1, fy1);
  return sat_box_integral_df(sat_corners_d(t.sat_d, t.sat, k, i0, j0, i1, j1), fx0, fy0, fx1, fy1);
}

// The prefiltered mean coverage of slice k over [x0, x1] x [y0, y1] (texel space), outside the
// texture counting as empty (the filters' box()): the exact box (summed-area tables), or the
// rectangle cut to the texture as squares (pyramids; an elongated cut that misses every covered
// texel is 0 without reads).
PN_INLINE float ot_box(OtTextures t, OtSliceBounds bounds, int k, float x0, float y0, float x1, float y1,
                       PN_INOUT(OtCounters) n) {
  n.lookups += 1u;
  float area = (x1 - x0) * (y1 - y0);
  float cx0 = max(x0, 0.0f);
  float cy0 = max(y0, 0.0f);
  float cx1 = min(x1, float(t.width));
  float cy1 = min(y1, float(t.height));
  if (!(cx1 > cx0 && cy1 > cy0 && area > 0.0f)) {
    n.outside += 1u;
    return 0.0f;
  }
  if (t.prefilter == kOtSat) {
    n.reads += 16u;
    return ot_sat_area(t, k, cx0, cy0, cx1, cy1) * (1.0f / area);
  }
  float sx = cx1 - cx0;
  float sy = cy1 - cy0;
  if (!(sx <= 1.25f * sy && sy <= 1.25f * sx)) {
    n.strips += 1u;
    if (!ot_bounds_meet(bounds, x0, y0, x1, y1)) return 0.0f;
  }
  float fraction = sx * sy / area;
  return fraction * ot_mean_over_squares(t, k, cx0, cy0, cx1, cy1, n);
}

// ---------------------------------------------------------------------------------------------
// Per point (occlusion_textures.cpp shade_batch)

// The slicing and the light's frame, 288 bytes (OcclusionTextures' set-up; a GPU record):
//   bytes 0-15 center, top   16-31 right, thickness   32-47 up, R (texture side)   48-63 forward, kx
//   bytes 64-79 ky, inv_fade, fade (0: no fade-in), slices
//   bytes 80-95 has_casters, combine (kOtProduct/Sum/Max), horizon (0 or 1), 0
//   bytes 96-223 scale[32]: per slice d / (plane(k) + d), the texel footprint per world unit
//   bytes 224-287 the light as the horizon test sees it (shadow/light_horizon_shared.h)
// right and up are the slicing view's axes; kx, ky texels per world unit at the light (R /
// width, R / height of its rectangle).
struct OtSetup {
  vec3 center;
  float top;
  vec3 right;
  float thickness;
  vec3 up;
  float R;
  vec3 forward;
  float kx;
  float ky;
  float inv_fade;
  uint fade;
  int slices;
  uint has_casters;
  uint combine;
  uint horizon;
  uint pad0;
  float scale[32];
  HorizonLight light;
};

// Slice k's texture plane: its far plane, at depth top + (k + 1) T.
PN_INLINE float ot_plane(OtSetup s, int k) {
  PN_PRECISE float z = s.top + float(k + 1) * s.thickness;
  return z;
}

// How many slices lie between the light and a point at depth z (their planes before z).
PN_INLINE int ot_slices_above(OtSetup s, float z) {
  int a = 0;
  if (s.has_casters != 0u && z > 0.0f) {
    a = min(max(int(pn_ceilf((z - s.top) / s.thickness)) - 1, 0), s.slices);
    while (a > 0 && !(ot_plane(s, a - 1) < z)) --a;
    while (a < s.slices && ot_plane(s, a) < z) ++a;
  }
  return a;
}

// The kernel of slice k (plane zp = ot_plane(k)) for a point at (u, v, z) in the light's frame
// (inv_z = 1 / z), eq. 4: the light seen from the point cuts the plane in a square of t x its
// size, t = (z - zp) / z, centred where the segment to the light's centre crosses it; in texels
// its side is t R d / (zp + d) (at least 1) and its centre R/2 + u (zp / z) (d / (zp + d)) kx
// (rows downward in y).
struct OtKernel {
  float cx;
  float cy;
  float side;
};
PN_INLINE OtKernel ot_kernel(OtSetup s, int k, float zp, float u, float v, float z, float inv_z) {
  float scale = s.scale[k];
  float half_r = 0.5f * s.R;
  float side_scale = scale * s.R;
  float a = scale * zp * inv_z;
  OtKernel r;
  PN_PRECISE float cx = half_r + u * a * s.kx;
  PN_PRECISE float cy = half_r - v * a * s.ky;
  r.cx = cx;
  r.cy = cy;
  r.side = max(1.0f, (z - zp) * inv_z * side_scale);
  return r;
}

// A slice's occlusion `occ` at a point of depth z, faded in below its plane zp (§3.4), into the
// three combinations (eq. 5's product, the sum, the largest).
struct OtCombined {
  float product;
  float sum;
  float largest;
};
PN_INLINE void ot_accumulate(OtSetup s, PN_INOUT(OtCombined) c, float z, float zp, float occ) {
  float w = s.fade != 0u ? min(1.0f, (z - zp) * s.inv_fade) : 1.0f;
  float o = w * occ;
  c.product *= 1.0f - o;  // eq. 5
  c.sum += o;
  c.largest = max(c.largest, o);
}
PN_INLINE float ot_combine(OtSetup s, OtCombined c) {
  if (s.combine == kOtSum) return max(0.0f, 1.0f - c.sum);
  if (s.combine == kOtMax) return 1.0f - c.largest;
  return c.product;
}

// The share of the light a receiver on a closed object can see at most (OtSetup::horizon): the
// part of the light above its tangent plane (normal ng); the rest is behind the object itself.
// The slices cannot show it: the slice holding the receiver is skipped and the one above fades in
// (§3.4), and a closed object's faces away from the centre of projection are not sliced, so a
// wall or a bunny's flank facing away from the light read as lit. 1 on open surfaces or with
// horizon off.
PN_INLINE float ot_horizon(OtSetup s, vec3 p, vec3 ng, bool closed) {
  return (s.horizon != 0u && closed) ? light_fraction_above(s.light, p, ng) : 1.0f;
}

// V at point p (OcclusionTextures::visibility): 0 behind the light's plane, 1 without casters,
// else eq. 5 over the slices above p, each looked up over its kernel. `bounds`: every slice's
// covered rectangle (for the pyramids' elongated kernels), 4 floats a slice. The slices alone:
// shading multiplies by ot_horizon.
PN_INLINE float ot_visibility(OtSetup s, OtTextures t, PN_FLOAT_ARRAY bounds, vec3 p, PN_INOUT(OtCounters) n) {
  vec3 q = p - s.center;
  float u = dot(q, s.right);
  float v = dot(q, s.up);
  float z = dot(q, s.forward);
  if (!(z > 0.0f)) return 0.0f;
  if (s.has_casters == 0u) return 1.0f;
  float inv_z = 1.0f / z;
  int above = ot_slices_above(s, z);
  OtCombined c;
  c.product = 1.0f;
  c.sum = 0.0f;
  c.largest = 0.0f;
  for (int k = 0; k < above; ++k) {
    float zp = ot_plane(s, k);
    OtKernel kern = ot_kernel(s, k, zp, u, v, z, inv_z);
    float half_side = 0.5f * max(kern.side, 1.0f);
    OtSliceBounds b;
    b.x0 = PN_AT(bounds, 4u * uint(k));
    b.y0 = PN_AT(bounds, 4u * uint(k) + 1u);
    b.x1 = PN_AT(bounds, 4u * uint(k) + 2u);
    b.y1 = PN_AT(bounds, 4u * uint(k) + 3u);
    float occ = ot_box(t, b, k, kern.cx - half_side, kern.cy - half_side, kern.cx + half_side, kern.cy + half_side, n);
    ot_accumulate(s, c, z, zp, occ);
  }
  return ot_combine(s, c);
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::OtSetup) == 288);
static_assert(sizeof(penumbra::shader::OtSliceBounds) == 16);
#endif

#endif  // PENUMBRA_SHADOW_OCCLUSION_TEXTURES_OCCLUSION_SHARED_H
