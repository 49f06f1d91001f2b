// The per-sample work of `vsm`, `evsm` and `msm` once for both devices (filtered_moments.h states
// the method): a view sample's normalised depth, the filtered mean over a rectangle of the
// moment map (summed-area table or mip chain, cut to the map), the receiver plane's variance,
// the light's part above a closed surface's tangent plane, and the two lookups (blocker search,
// then the filter). Common subset of C++ and GLSL (core/shader_compat.h); FilteredMomentShadows
// calls fm_shade for every view sample, the GPU kernel filtered_moments/kernels/
// fm_filter.comp for every slot. Also the GPU's records, byte by byte.
#ifndef PENUMBRA_SHADOW_FILTERED_MOMENTS_FILTERED_MOMENTS_SHARED_H
#define PENUMBRA_SHADOW_FILTERED_MOMENTS_FILTERED_MOMENTS_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/core/shader_compat_math.h"
#include "penumbra/raster/filtered_map_shared.h"
#include "penumbra/shadow/filtered_moments/moments_shared.h"
#include "penumbra/shadow/light_horizon_shared.h"
#include "penumbra/shadow/shadow_map_shared.h"

PN_SHARED_BEGIN

PN_CONST uint kFmPrefilterSat = 0u;
PN_CONST uint kFmPrefilterMip = 1u;

// How a depth map's linear depths map to normalised depths (FilteredMomentMap::normalize): affine
// in 1/z over the map's covered range onto [near, far] (0.05, 0.95), 32 bytes (a GPU record the
// encode kernel writes): bytes 0-7 inv_lo (1 / the nearest covered depth), 8-15 scale
// ((far - near) / (1/lo - 1/hi)), 16-23 near, 24-31 far.
struct FmDepthRange {
  double inv_lo;
  double scale;
  double near;
  double far;
};

// The range of a map whose covered linear depths span [lo, hi] (lo > hi: an empty map, whose
// every lookup reads "nothing"); a map of one depth still needs a range (any positive one: its
// texels are all at near): at least tiny / lo in 1/z.
PN_INLINE FmDepthRange fm_depth_range(float lo, float hi, double near, double far, double tiny) {
  if (!(lo <= hi)) {
    lo = 1.0f;
    hi = 1.0f;
  }
  FmDepthRange r;
  r.inv_lo = double(1.0f) / double(lo);
  double range = pn_dmax(double(1.0f) / double(lo) - double(1.0f) / double(hi), tiny / double(lo));
  r.scale = (far - near) / range;
  r.near = near;
  r.far = far;
  return r;
}

PN_INLINE double fm_normalize(FmDepthRange r, float z) {
  PN_PRECISE double d = r.near + (r.inv_lo - double(1.0f) / double(z)) * r.scale;
  return d;
}
PN_INLINE double fm_inverse_depth(FmDepthRange r, double d) { return r.inv_lo - (d - r.near) / r.scale; }

// What a texel of linear depth z (+inf: empty) stores: the moments of its normalised depth, an
// empty texel those of depth 1 (nothing in front of anything). The CPU stores them as floats.
PN_INLINE FilteredChannels fm_encode_texel(FmModel model, FmDepthRange r, float z) {
  bool covered = floatBitsToUint(z) < 0x7f800000u;  // z < +inf (depths are positive), from the bits
  return fm_encode(model, covered ? clamp(fm_normalize(r, z), r.near, r.far) : double(1.0f));
}

// The moment map as a lookup reads it: a summed-area table (doubles, channels interleaved) or a
// mip chain (raster/filtered_map_shared.h), with the map's size and depth range. Built where it
// is used (a C++ pointer or a GLSL buffer reference per table), never stored.
struct FmMapRef {
  uint prefilter;  // kFmPrefilter*
  int width;
  int height;
  PN_DOUBLE_ARRAY sat;
  SatTableLayout sat_layout;
  FilteredChannels outside;  // the moments of an empty texel (depth 1)
  PN_FLOAT_ARRAY mip;
  MipChainView mip_view;
  FmDepthRange range;
};

// FilteredMomentMap::mean: the mean vector over [x0, x1] x [y0, y1] (texel space) cut to the map:
// the map is fitted to the receivers, so beyond its edge lie casters it did not keep, not empty
// space. A region wholly outside reads empty.
PN_INLINE FilteredChannels fm_mean(FmMapRef r, double x0, double y0, double x1, double y1) {
  double cx0 = pn_dmax(x0, double(0.0f));
  double cy0 = pn_dmax(y0, double(0.0f));
  double cx1 = pn_dmin(x1, double(r.width));
  double cy1 = pn_dmin(y1, double(r.height));
  if (cx1 > cx0 && cy1 > cy0) {
    x0 = cx0;
    y0 = cy0;
    x1 = cx1;
    y1 = cy1;
  }
  if (r.prefilter == kFmPrefilterSat) return sat_box_mean(r.sat, r.sat_layout, r.outside, x0, y0, x1, y1);
  return mip_box_mean(r.mip, r.mip_view, float(x0), float(y0), float(x1), float(y1));
}

// What every lookup of one map and light reads, 288 bytes (a GPU record, uploaded per frame):
//   bytes 0-175 the map's ShadowMapView (shadow/shadow_map_shared.h: view, focal, z_min)
//   bytes 176-239 the HorizonLight (shadow/light_horizon_shared.h)
//   bytes 240-247 half_extent: texels per unit of (1/z_b - 1/z_p) along x and y (the light's rectangle
//                 as light_half_extent sees it, times the focal length)
//   bytes 248-255 min_half: half the smallest filter side, texels (double)
//   bytes 256-263 fixed_half: half the fixed filter side without the blocker search (double)
//   bytes 264-267 bias (world units of linear depth)   268-271 blocker_search (0 or 1)
//   bytes 272-279 min_fraction: a blocker search finding less is the receiver's own surface in
//                 the Chebyshev bound's tail (1e-4)
//   bytes 280-283 subdivide: the most sub-regions a side a search or filter region is split
//                 into (fm_parts; 1: never)
//   bytes 284-287 near_field: texels (fm_near_field_length; 0: none)
//   bytes 288-291 light_width: near_field_light_width of the light   292-295 (0)
struct FmShadeBlock {
  ShadowMapView map;
  HorizonLight light;
  vec2 half_extent;
  double min_half;
  double fixed_half;
  float bias;
  uint blocker_search;
  double min_fraction;
  uint subdivide;
  float near_field;
  float light_width;
  uint pad0;
};

// The slope of p's tangent plane in normalised depth per texel along x and y: 1/z is affine in
// texel space along a plane, with gradient (plane_a, plane_b) / plane_num (sm_receiver), and so
// is the normalised depth. Zero where the plane is seen edge-on.
struct FmPlaneSlope {
  double x;
  double y;
};
PN_INLINE FmPlaneSlope fm_receiver_slope(FmShadeBlock b, FmDepthRange range, vec3 p, vec3 ng) {
  ShadowBias none;
  none.bias = 0.0f;
  none.slope_bias = 0.0f;
  none.max_slope = 10.0f;
  none.receiver_plane = 0u;
  ShadowReceiver rc = sm_receiver(b.map, p, ng, none);
  FmPlaneSlope g;
  g.x = double(0.0f);
  g.y = double(0.0f);
  if (rc.plane_num == 0.0f) return g;
  double k = -range.scale / double(rc.plane_num);
  g.x = k * double(rc.plane_a);
  g.y = k * double(rc.plane_b);
  return g;
}

// The variance (normalised depth^2) of the tangent plane of slope g over a box of half extents
// (sx, sy) texels: a linear ramp of slopes g over a box has variance (g_x^2 sx^2 + g_y^2 sy^2) / 3.
// The blocker estimates take it out of the search region's spread: it lies around t, not in
// front of it (bunny: vsm MAE 0.050 -> 0.035).
PN_INLINE double fm_receiver_variance(FmPlaneSlope g, double sx, double sy) {
  PN_PRECISE double v = g.x * g.x * sx * sx + g.y * g.y * sy * sy;
  return v / double(3.0f);
}

// Sub-regions a side for a region of half extent `half_side` texels: one per two texels, at most
// `subdivide`, at least one. Yang et al. 2010 (variance soft shadow mapping, §4) split a kernel
// whose moments cannot be trusted as one distribution; a canopy's search and filter regions
// hold blockers in front of the receiver and the ground far behind it at once, and one bound over
// both calls the receiver lit wherever it lies in front of their mean (light bleeding). Each part
// holds fewer depths, and is compared with the receiver plane's depth at its own centre.
PN_INLINE int fm_parts(double half_side, uint subdivide) {
  return int(clamp(ceil(half_side), double(1.0f), double(subdivide)));
}

// Part (i, j) of n_x x n_y of the box [cx - hx, cx + hx] x [cy - hy, cy + hy] (texels). Its
// outer sides are the box's own, bit for bit (one part is the whole box).
struct FmBox {
  double x0;
  double y0;
  double x1;
  double y1;
};
PN_INLINE FmBox fm_part_box(double cx, double cy, double hx, double hy, int i, int j, int nx, int ny) {
  FmBox r;
  r.x0 = cx + hx * (double(2 * i - nx) / double(nx));
  r.x1 = cx + hx * (double(2 * i + 2 - nx) / double(nx));
  r.y0 = cy + hy * (double(2 * j - ny) / double(ny));
  r.y1 = cy + hy * (double(2 * j + 2 - ny) / double(ny));
  return r;
}

// The receiver plane's normalised depth at the centre of box r, from t at (cx, cy), kept in
// [0, far] as t is. (A region in one part compares with t itself: the single estimate of before,
// bit for bit.)
PN_INLINE double fm_plane_depth(double t, FmPlaneSlope g, double cx, double cy, FmBox r, double far) {
  PN_PRECISE double d = t + g.x * (double(0.5f) * (r.x0 + r.x1) - cx) + g.y * (double(0.5f) * (r.y0 + r.y1) - cy);
  return clamp(d, double(0.0f), far);
}

// What one view sample's shading did: the filtered lookups it made, and whether its blocker
// search found no blocker (samples_without_blockers).
struct FmShadeCount {
  uint lookups;
  uint unblocked;
};

// V of one view sample (FilteredMomentShadows::evaluate): 0 behind the light's plane; on a closed
// object only the light above its tangent plane counts (the rest is hidden by the object itself);
// lit where the map does not cover it; otherwise the blocker search (PCSS's step 1 over the
// light projected through p onto the nearest caster's depth, the blockers' fraction and depth
// from the moments), the penumbra estimate (the light's shape scaled by 1/d_b - 1/z_p; the
// smallest filter where the search found no blocker) and the filtered lookup, the model's
// visibility from its moments.
PN_INLINE float fm_shade(FmMapRef map, FmModel model, FmShadeBlock b, vec3 p, vec3 ng, bool closed,
                         PN_INOUT(FmShadeCount) count) {
  if (!sm_in_front_of_light(b.light.center, b.light.n, p)) return 0.0f;
  float horizon = closed ? light_fraction_above(b.light, p, ng) : 1.0f;
  if (!(horizon > 0.0f)) return 0.0f;
  // LightView::to_texel.
  RasterView v = b.map.view;
  vec3 d = p - v.eye;
  float w = sm_row(v.row3, v.off3, d);
  float tz = sm_row(v.row2, v.off2, d);
  float tx = sm_row(v.row0, v.off0, d) / w;
  float ty = sm_row(v.row1, v.off1, d) / w;
  if (!(tz >= v.near && tx >= 0.0f && ty >= 0.0f && tx < float(v.width) && ty < float(v.height)))
    return horizon;  // not covered by the map (beyond max_fov): lit
  // Normalised like the texels (a receiver behind every covered depth compares as the farthest
  // one: empty texels, at 1, never block).
  double t = clamp(fm_normalize(map.range, tz - sm_constant_bias(b.bias, tz, sm_texel_size(v, tz), p, 0.0f)), double(0.0f),
                   map.range.far);
  double hx = b.fixed_half;
  double hy = hx;
  FmPlaneSlope slope = fm_receiver_slope(b, map.range, p, ng);
  if (b.blocker_search != 0u) {
    // 1. Blocker search: the light projected through p onto z_min.
    float z_min = b.map.z_min;
    double search = tz > z_min ? double(1.0f) / double(z_min) - double(1.0f) / double(tz) : double(0.0f);
    double sx = pn_dmax(double(b.half_extent.x) * search, b.min_half);
    double sy = pn_dmax(double(b.half_extent.y) * search, b.min_half);
    // In parts (fm_parts): the blockers' fraction is the parts' mean, their depth the mean of
    // the parts' depths weighted by their fractions (a part finding none adds nothing).
    int nx = fm_parts(sx, b.subdivide);
    int ny = fm_parts(sy, b.subdivide);
    double part_variance = fm_receiver_variance(slope, sx / double(nx), sy / double(ny));
    FmBlockers blockers;
    blockers.fraction = double(0.0f);
    blockers.depth = double(0.0f);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        FmBox r = fm_part_box(double(tx), double(ty), sx, sy, i, j, nx, ny);
        double d = nx * ny == 1 ? t : fm_plane_depth(t, slope, double(tx), double(ty), r, map.range.far);
        FmBlockers part = fm_model_blockers(model, fm_mean(map, r.x0, r.y0, r.x1, r.y1), d, part_variance);
        if (nx * ny == 1) {
          blockers = part;
        } else if (part.fraction > b.min_fraction) {
          blockers.fraction += part.fraction;
          blockers.depth += part.fraction * part.depth;
        }
      }
    count.lookups += uint(nx * ny);
    if (nx * ny > 1) {
      if (blockers.fraction > double(0.0f)) blockers.depth /= blockers.fraction;
      blockers.fraction /= double(nx * ny);
    }
    if (!(blockers.fraction > b.min_fraction)) {
      // No blocker found. PCSS's exact search may call that lit; the moments' estimate may not:
      // where the search region holds many depths at once (a canopy, a contact, an umbra's
      // edge) and the receiver lies in front of their mean, the one-sided bound knows nothing and
      // the estimate says "none" over real blockers (light bleeding into the search). So the
      // receiver's own texels decide: the smallest filter (issue 34; forest vsm 0.177 -> 0.051,
      // bunny 0.035 -> 0.023 mean |dV|, docs/methods/vsm.md). Where it is truly lit, that says 1.
      count.unblocked += 1u;
      hx = double(0.0f);
      hy = double(0.0f);
    } else {
      // 2. Penumbra estimate: the light's shape scaled by (1/d_b - 1/z_p) (PCSS). No caster lies
      // nearer than the map's nearest one (the estimates can undershoot).
      double scale = pn_dmax(double(0.0f), fm_inverse_depth(map.range, pn_dmax(blockers.depth, map.range.near)) -
                                               double(1.0f) / double(tz));
      hx = double(b.half_extent.x) * scale;
      hy = double(b.half_extent.y) * scale;
    }
  }
  hx = pn_dmax(hx, b.min_half);
  hy = pn_dmax(hy, b.min_half);
  // 3. The filter, in parts as the search: V is the mean of the parts' visibilities.
  int nx = fm_parts(hx, b.subdivide);
  int ny = fm_parts(hy, b.subdivide);
  float sum = 0.0f;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      FmBox r = fm_part_box(double(tx), double(ty), hx, hy, i, j, nx, ny);
      double d = nx * ny == 1 ? t : fm_plane_depth(t, slope, double(tx), double(ty), r, map.range.far);
      sum += clamp(fm_model_visibility(model, fm_mean(map, r.x0, r.y0, r.x1, r.y1), d), 0.0f, 1.0f);
    }
  count.lookups += uint(nx * ny);
  return horizon * (sum / float(nx * ny));
}

// The near field (penumbra's addition, docs/methods/vsm.md "The near field"): where an occluder's
// penumbra at p would be narrower than near_field texels of the map (sm_near_field_length), the
// filtered map draws it no narrower than its smallest filter and from a mix of depths (light
// bleeding through a canopy). There a penumbra that narrow is close to the hard shadow, so one ray
// toward the light's centre (the map's eye) is traced over that part and V is multiplied by its
// transmittance, as hybrid ray-traced shadows blend a ray-traced hard shadow near the contact with
// a filtered one (Story 2015). The length, or 0 for no ray: where the map already says dark (v 0),
// without a near field, and on a closed object whose own surface hides the light's centre (its
// horizon, light_fraction_above, answers there).
PN_INLINE float fm_near_field_length(FmShadeBlock b, vec3 p, vec3 ng, bool closed, float v) {
  if (!(v > 0.0f) || !(b.near_field > 0.0f)) return 0.0f;
  if (closed && !(dot(ng, b.map.view.eye - p) > 0.0f)) return 0.0f;
  return sm_near_field_length(b.map, p, b.near_field, b.light_width);
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::FmDepthRange) == 32);
static_assert(sizeof(penumbra::shader::FmShadeBlock) == 296);
#endif

#endif  // PENUMBRA_SHADOW_FILTERED_MOMENTS_FILTERED_MOMENTS_SHARED_H
