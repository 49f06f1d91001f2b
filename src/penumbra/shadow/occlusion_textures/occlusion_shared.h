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
#include "penumbra/shadow/near_field_shared.h"

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

// The slicing and the light's frame, 192 bytes (OcclusionTextures' set-up; a GPU record):
//   bytes 0-15 center, R (texture side)   16-31 right, kx   32-47 up, ky   48-63 forward, d
//   bytes 64-79 fade_length (slice thicknesses), fade (0: no fade-in), slices, has_casters
//   bytes 80-95 combine (kOtProduct/Sum/Max), horizon (0 or 1), tiles, tile_scale
//   bytes 96-111 top, thickness (the whole range's slices), tile_side (texels), open_fade_length
//   bytes 112-175 the light as the horizon test sees it (shadow/light_horizon_shared.h)
//   bytes 176-191 near_field (texels; 0: none), light_width (near_field_light_width), 2 x (0)
// right and up are the slicing view's axes; kx, ky texels per world unit at the light (R /
// width, R / height of its rectangle); d the centre of projection's distance behind the light.
// The slices of each light-space tile (`tiles` x `tiles` of them, tile_side = R / tiles texels a
// side, tile_scale = 1 / tile_side) follow in an OtTile array, row-major from the texture's
// top-left corner (on the GPU right after the set-up in its buffer, as floats: top, thickness); a
// tile sliced over the whole range holds exactly (top, thickness).
PN_CONST uint kOtSetupBytes = 192u;  // sizeof(OtSetup): where the OtTile array starts on the GPU
struct OtSetup {
  vec3 center;
  float R;
  vec3 right;
  float kx;
  vec3 up;
  float ky;
  vec3 forward;
  float d;
  float fade_length;
  uint fade;
  int slices;
  uint has_casters;
  uint combine;
  uint horizon;
  int tiles;
  float tile_scale;
  float top;
  float thickness;
  float tile_side;
  float open_fade_length;  // fade_length for receivers on open surfaces (0: no fade-in)
  HorizonLight light;
  float near_field;   // ot_near_field_length
  float light_width;
  uint pad0;
  uint pad1;
};

// One light-space tile's slices, 8 bytes: slice k spans depths [top + k thickness, top + (k +
// 1) thickness] (the depth range of the casters the tile's texels see, cut in `slices`).
struct OtTile {
  float top;
  float thickness;
};

// A tile's slices as a point uses them: with the fade-in's 1 / (fade_length thickness), 0 for no
// fade-in.
struct OtSlicing {
  float top;
  float thickness;
  float inv_fade;
};

// Slices from `top`, `thickness` apart, as a point on an open surface or not uses them. A
// receiver on an open surface (a leaf, a card, a plane) fades the slice above in over
// open_fade_length thicknesses instead of fade_length: in a canopy the occluders of a leaf are
// its neighbours a slice above, which a whole thickness's fade-in leaves out, while a closed
// object's faces crossing a slice plane need it (docs/methods/occlusion-textures.md).
PN_INLINE OtSlicing ot_slicing(OtSetup s, float top, float thickness, bool open) {
  OtSlicing c;
  c.top = top;
  c.thickness = thickness;
  float length = open ? s.open_fade_length : (s.fade != 0u ? s.fade_length : 0.0f);
  c.inv_fade = length > 0.0f ? 1.0f / (length * thickness) : 0.0f;
  return c;
}

// The slicing of tile i (`tiles`: the OtTile array as floats).
PN_INLINE OtSlicing ot_tile_slicing(OtSetup s, PN_FLOAT_ARRAY tiles, int i, bool open) {
  return ot_slicing(s, PN_AT(tiles, 2u * uint(i)), PN_AT(tiles, 2u * uint(i) + 1u), open);
}

// Slice k's texture plane: its far plane, at depth top + (k + 1) T.
PN_INLINE float ot_plane(OtSlicing c, int k) {
  PN_PRECISE float z = c.top + float(k + 1) * c.thickness;
  return z;
}

// How many slices lie between the light and a point at depth z (their planes before z).
PN_INLINE int ot_slices_above(OtSetup s, OtSlicing c, float z) {
  int a = 0;
  if (s.has_casters != 0u && z > 0.0f) {
    a = min(max(int(pn_ceilf((z - c.top) / c.thickness)) - 1, 0), s.slices);
    while (a > 0 && !(ot_plane(c, a - 1) < z)) --a;
    while (a < s.slices && ot_plane(c, a) < z) ++a;
  }
  return a;
}

// The kernel of a slice (plane zp = ot_plane(k)) for a point at (u, v, z) in the light's frame
// (inv_z = 1 / z), eq. 4: the light seen from the point cuts the plane in a square of t x its
// size, t = (z - zp) / z, centred where the segment to the light's centre crosses it; in texels
// its side is t R d / (zp + d) (at least 1) and its centre R/2 + u (zp / z) (d / (zp + d)) kx
// (rows downward in y): d / (zp + d) is the plane's texels per world unit over those at the light.
struct OtKernel {
  float cx;
  float cy;
  float side;
};
PN_INLINE OtKernel ot_kernel(OtSetup s, float zp, float u, float v, float z, float inv_z) {
  float scale = s.d / (zp + s.d);
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
PN_INLINE float ot_fade_weight(float z, float zp, float inv_fade) {
  return inv_fade > 0.0f ? min(1.0f, (z - zp) * inv_fade) : 1.0f;
}
// Slice k's weight at a point of depth z: its fade-in (above), times the part of its depth band
// [zp - thickness, zp] beyond the point's near field, nearer the light than z - near_z
// (ot_near_field_depth): the near field's ray answers for the occluders within it, the slices
// for the rest, so that none counts twice (a leaf's neighbours a few centimetres above it are in
// both the ray and the slices above it). near_z 0: the fade alone.
PN_INLINE float ot_slice_weight(OtSlicing c, float z, float zp, float near_z) {
  float w = ot_fade_weight(z, zp, c.inv_fade);
  if (near_z > 0.0f) w *= clamp((z - near_z - zp) / c.thickness + 1.0f, 0.0f, 1.0f);
  return w;
}
PN_INLINE void ot_combine_add(PN_INOUT(OtCombined) c, float o) {
  c.product *= 1.0f - o;  // eq. 5
  c.sum += o;
  c.largest = max(c.largest, o);
}
PN_INLINE void ot_accumulate(PN_INOUT(OtCombined) c, OtSlicing slicing, float z, float zp, float near_z, float occ) {
  float o = ot_slice_weight(slicing, z, zp, near_z) * occ;
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

// The near field (penumbra's addition, issue 34; shadow/near_field_shared.h): the length of the
// segment from p toward the light's centre that is traced through the scene, where an occluder's
// penumbra at p would be narrower than `near_field` texels of the textures at p's depth (a texel
// there is (z + d) / (d k) world units: ot_kernel's centre at zp = z). A slice's filtered coverage
// cannot place such an occluder: a leaf a few centimetres above another, one texel of the 16
// slices' coverage, which eq. 5 spreads over the kernel. 0 without a near field, behind the
// light, or on a closed object whose own surface hides the light's centre (the horizon answers
// there).
PN_INLINE float ot_near_field_length(OtSetup s, vec3 p, vec3 ng, bool closed) {
  if (!(s.near_field > 0.0f) || s.has_casters == 0u) return 0.0f;
  vec3 q = p - s.center;
  float z = dot(q, s.forward);
  if (!(z > 0.0f)) return 0.0f;
  if (closed && !(dot(ng, -q) > 0.0f)) return 0.0f;
  float texel = (z + s.d) / (s.d * min(s.kx, s.ky));
  return near_field_length(s.near_field * texel, length(q), s.light_width);
}
// The depth (along the light's forward axis) the near field of length `near` spans from p: the
// slices' share of it is left to the ray (ot_slice_weight).
PN_INLINE float ot_near_field_depth(OtSetup s, vec3 p, float near) {
  vec3 q = p - s.center;
  float len = length(q);
  return near > 0.0f && len > 0.0f ? near * dot(q, s.forward) / len : 0.0f;
}

// A slice's kernel as a texel rectangle, [x0, x1) x [y0, y1), at least a texel a side.
PN_INLINE OtSliceBounds ot_kernel_rect(OtKernel kern) {
  float half_side = 0.5f * max(kern.side, 1.0f);
  OtSliceBounds r;
  r.x0 = kern.cx - half_side;
  r.y0 = kern.cy - half_side;
  r.x1 = kern.cx + half_side;
  r.y1 = kern.cy + half_side;
  return r;
}

// Slice k's covered rectangle (`bounds`: 4 floats a slice).
PN_INLINE OtSliceBounds ot_slice_bounds(PN_FLOAT_ARRAY bounds, int k) {
  OtSliceBounds b;
  b.x0 = PN_AT(bounds, 4u * uint(k));
  b.y0 = PN_AT(bounds, 4u * uint(k) + 1u);
  b.x1 = PN_AT(bounds, 4u * uint(k) + 2u);
  b.y1 = PN_AT(bounds, 4u * uint(k) + 3u);
  return b;
}

// The tiles a point's kernels can reach, [x0, x1] x [y0, y1]: those the largest kernel (at the
// casters' nearest depth) and the point's own projection span.
struct OtTileRange {
  int x0;
  int y0;
  int x1;
  int y1;
};
PN_INLINE OtTileRange ot_reach(OtSetup s, float u, float v, float z) {
  float inv_z = 1.0f / z;
  OtSliceBounds widest = ot_kernel_rect(ot_kernel(s, s.top, u, v, z, inv_z));
  OtKernel own = ot_kernel(s, z, u, v, z, inv_z);
  float last = float(s.tiles - 1);
  OtTileRange r;
  r.x0 = int(min(max(floor(min(widest.x0, own.cx) * s.tile_scale), 0.0f), last));
  r.x1 = int(min(max(floor(max(widest.x1, own.cx) * s.tile_scale), 0.0f), last));
  r.y0 = int(min(max(floor(min(widest.y0, own.cy) * s.tile_scale), 0.0f), last));
  r.y1 = int(min(max(floor(max(widest.y1, own.cy) * s.tile_scale), 0.0f), last));
  return r;
}

// Whether every tile of a range is sliced over the whole range: the point's pieces of each slice
// then lie in one plane and make the whole kernel, one lookup (ot_visibility's plain path).
PN_INLINE bool ot_reach_is_whole(OtSetup s, PN_FLOAT_ARRAY tiles, OtTileRange r) {
  bool whole = true;
  for (int ty = r.y0; ty <= r.y1; ++ty)
    for (int tx = r.x0; tx <= r.x1; ++tx) {
      uint i = uint(ty * s.tiles + tx);
      whole = whole && PN_AT(tiles, 2u * i) == s.top && PN_AT(tiles, 2u * i + 1u) == s.thickness;
    }
  return whole;
}

// V at p over the slices of light-space tiles (tiles > 1). Slice k is then a surface that lies at
// the tile's own plane k in each tile's part of the texture, so the light seen from p cuts it in
// pieces: in each tile, the kernel of that tile's plane k (eq. 4), cut to the tile. Slice k's
// occlusion is the sum over the tiles of each piece's covered area (each piece faded in by its
// own plane's distance above p), over the kernel's area; eq. 5 combines the slices. With one
// tile this is ot_visibility's single lookup per slice. The tiles visited: `reach` (ot_reach);
// `open`: the point is on an open surface (ot_slicing's fade); `near_z`: ot_slice_weight's.
PN_INLINE float ot_visibility_tiled(OtSetup s, PN_FLOAT_ARRAY tiles, OtTextures t, PN_FLOAT_ARRAY bounds, float u,
                                    float v, float z, float near_z, OtTileRange reach, bool open,
                                    PN_INOUT(OtCounters) n) {
  float inv_z = 1.0f / z;
  float occ[kOtMaxSlices];
  float shares[kOtMaxSlices];
  for (int k = 0; k < s.slices; ++k) occ[k] = 0.0f;
  for (int k = 0; k < s.slices; ++k) shares[k] = 0.0f;
  for (int ty = reach.y0; ty <= reach.y1; ++ty) {
    for (int tx = reach.x0; tx <= reach.x1; ++tx) {
      OtSlicing slicing = ot_tile_slicing(s, tiles, ty * s.tiles + tx, open);
      int above = ot_slices_above(s, slicing, z);
      float rx0 = float(tx) * s.tile_side;
      float ry0 = float(ty) * s.tile_side;
      float rx1 = rx0 + s.tile_side;
      float ry1 = ry0 + s.tile_side;
      for (int k = 0; k < above; ++k) {
        float zp = ot_plane(slicing, k);
        OtSliceBounds kr = ot_kernel_rect(ot_kernel(s, zp, u, v, z, inv_z));
        float x0 = max(kr.x0, rx0);
        float y0 = max(kr.y0, ry0);
        float x1 = min(kr.x1, rx1);
        float y1 = min(kr.y1, ry1);
        if (!(x1 > x0 && y1 > y0)) continue;
        PN_PRECISE float share = (x1 - x0) * (y1 - y0) / ((kr.x1 - kr.x0) * (kr.y1 - kr.y0));
        float covered = ot_box(t, ot_slice_bounds(bounds, k), k, x0, y0, x1, y1, n);
        occ[k] += ot_slice_weight(slicing, z, zp, near_z) * covered * share;
        shares[k] += share;
      }
    }
  }
  OtCombined c;
  c.product = 1.0f;
  c.sum = 0.0f;
  c.largest = 0.0f;
  for (int k = 0; k < s.slices; ++k) ot_combine_add(c, min(shares[k] > 1.0f ? occ[k] / shares[k] : occ[k], 1.0f));
  return ot_combine(s, c);
}

// The receiver's own slice (penumbra's addition, issue 34). eisemann2006 §3.4 leaves the slice
// holding a point out, and fades the one above in: its textures cannot tell an occluder above the
// point from the point's own surface. In a canopy that is most of a leaf's shadow: its occluders
// are leaves a few centimetres above, within its own slice (the 25-tree forest's leaves read 0.22
// mean |dV| without it, 0.074 with the exact answer from ray tracing the own slice, 0.030 for
// `hard`: docs/methods/occlusion-textures.md "The own slice"). So the slicing pass also keeps each
// slice's nearest depth per texel (a shadow map per slice, raster/rasterizer.h
// DepthBinMasks::nearest), and a receiver on an open surface tests it, as a shadow map does,
// against its own plane: a tap of the 2 x 2 texels around the point (bilinear weights, PCF) is
// in shadow where the slice holding the point there has a fragment nearer the light than the
// receiver's plane through that texel's centre, less a margin of 10^-4 of the depth (far above
// the float rounding of either depth; the plane keeps a tilted leaf from shadowing itself). The
// occluders are within a slice of the point, so their penumbra is narrow: a hard test. V of the
// own slice, in [0, 1]; `nearest`: the slices' planes of (scale R) x (scale R) depths (linear,
// from the centre of projection: d + z), row-major from the texture's top-left corner, 0 or
// +infinity where the slice has none (a shadow map's hard test wants finer texels than the
// filtered coverage: `own_slice_scale`); `tiles` as ot_visibility's. With a near field
// (ot_near_field_depth: near_z), a fragment counts only beyond it, nearer the light than the
// plane by more than near_z: the ray answers for the nearer ones.
PN_INLINE float ot_own_slice(OtSetup s, PN_FLOAT_ARRAY tiles, PN_FLOAT_ARRAY nearest, int scale, vec3 p, vec3 ng,
                             float near_z) {
  vec3 q = p - s.center;
  float u = dot(q, s.right);
  float v = dot(q, s.up);
  float z = dot(q, s.forward);
  if (!(z > 0.0f) || s.has_casters == 0u) return 1.0f;
  // Depth from the centre of projection, and the point's position in the nearest depths' texels
  // (ot_kernel's centre at zp = z, times scale).
  PN_PRECISE float dp = z + s.d;
  float at_light = s.d / dp;
  float m = float(scale);
  PN_PRECISE float px = (0.5f * s.R + u * at_light * s.kx) * m - 0.5f;
  PN_PRECISE float py = (0.5f * s.R - v * at_light * s.ky) * m - 0.5f;
  float fx0 = floor(px);
  float fy0 = floor(py);
  float wx = px - fx0;
  float wy = py - fy0;
  // The receiver's plane n.(x - p) = 0 along the ray from the centre of projection through a
  // texel's centre (u = a (z + d), v = b (z + d)): depth = (n_r u_p + n_u v_p + n_f dp) /
  // (n_r a + n_u b + n_f).
  float nr = dot(ng, s.right);
  float nu = dot(ng, s.up);
  float nf = dot(ng, s.forward);
  PN_PRECISE float num = nr * u + nu * v + nf * dp;
  int side = int(s.R) * scale;
  float lit = 0.0f;
  for (int j = 0; j < 2; ++j) {
    for (int i = 0; i < 2; ++i) {
      float w = (i == 0 ? 1.0f - wx : wx) * (j == 0 ? 1.0f - wy : wy);
      int x = int(fx0) + i;
      int y = int(fy0) + j;
      if (x < 0 || y < 0 || x >= side || y >= side) {
        lit += w;  // beyond the texture: no caster
        continue;
      }
      OtSlicing slicing = ot_slicing(s, s.top, s.thickness, true);
      if (s.tiles > 1) {
        int tx = min(int(float(x / scale) * s.tile_scale), s.tiles - 1);
        int ty = min(int(float(y / scale) * s.tile_scale), s.tiles - 1);
        slicing = ot_tile_slicing(s, tiles, ty * s.tiles + tx, true);
      }
      int k = ot_slices_above(s, slicing, z);  // the slice holding the point there
      if (k >= s.slices) {
        lit += w;  // below every slice of this texel: nothing sliced at its depth
        continue;
      }
      PN_PRECISE float a = ((float(x) + 0.5f) / m - 0.5f * s.R) / (s.kx * s.d);
      PN_PRECISE float b = (0.5f * s.R - (float(y) + 0.5f) / m) / (s.ky * s.d);
      PN_PRECISE float den = nr * a + nu * b + nf;
      // The plane's depth there, within a slice of the point's (a plane grazing the ray from
      // the centre of projection has no useful depth at the next texel).
      float plane = dp;
      if (num * den > 0.0f) plane = clamp(num / den, dp - slicing.thickness, dp + slicing.thickness);
      float nearest_depth = PN_AT(nearest, (uint(k) * uint(side) + uint(y)) * uint(side) + uint(x));
      // An empty bin holds 0 (the CPU's zeroed pages) or +infinity (the GPU's atomicMin start).
      if (!(nearest_depth > 0.0f && nearest_depth < plane - max(1e-4f * dp, near_z))) lit += w;
    }
  }
  return lit;
}

// V at point p (OcclusionTextures::visibility): 0 behind the light's plane, 1 without casters,
// else eq. 5 over the slices above p, each looked up over its kernel (the whole range's slices;
// where a tile the point's kernels reach has slices of its own, the tiles' pieces:
// ot_visibility_tiled). `bounds`: every slice's covered rectangle
// (for the pyramids' elongated kernels), 4 floats a slice; `tiles`: the OtTile array as floats.
// The slices alone: shading multiplies by ot_horizon. `open`: p is on an open surface (ot_slicing);
// `near_z`: the depth of its near field (ot_near_field_depth; 0: none), whose share of the slices
// is left out (ot_slice_weight).
PN_INLINE float ot_visibility(OtSetup s, PN_FLOAT_ARRAY tiles, OtTextures t, PN_FLOAT_ARRAY bounds, vec3 p, bool open,
                              float near_z, PN_INOUT(OtCounters) n) {
  vec3 q = p - s.center;
  float u = dot(q, s.right);
  float v = dot(q, s.up);
  float z = dot(q, s.forward);
  if (!(z > 0.0f)) return 0.0f;
  if (s.has_casters == 0u) return 1.0f;
  OtSlicing slicing = ot_slicing(s, s.top, s.thickness, open);
  if (s.tiles > 1) {
    OtTileRange reach = ot_reach(s, u, v, z);
    if (!ot_reach_is_whole(s, tiles, reach))
      return ot_visibility_tiled(s, tiles, t, bounds, u, v, z, near_z, reach, open, n);
  }
  float inv_z = 1.0f / z;
  int above = ot_slices_above(s, slicing, z);
  OtCombined c;
  c.product = 1.0f;
  c.sum = 0.0f;
  c.largest = 0.0f;
  for (int k = 0; k < above; ++k) {
    float zp = ot_plane(slicing, k);
    OtSliceBounds kr = ot_kernel_rect(ot_kernel(s, zp, u, v, z, inv_z));
    float occ = ot_box(t, ot_slice_bounds(bounds, k), k, kr.x0, kr.y0, kr.x1, kr.y1, n);
    ot_accumulate(c, slicing, z, zp, near_z, occ);
  }
  return ot_combine(s, c);
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::OtSetup) == penumbra::shader::kOtSetupBytes);
static_assert(sizeof(penumbra::shader::OtTile) == 8);
static_assert(sizeof(penumbra::shader::OtSliceBounds) == 16);
#endif

#endif  // PENUMBRA_SHADOW_OCCLUSION_TEXTURES_OCCLUSION_SHARED_H
