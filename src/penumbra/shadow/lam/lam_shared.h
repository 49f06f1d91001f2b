// Layered attenuation maps' per-pixel and per-texel math once for both devices, in the common
// subset of C++ and GLSL (core/shader_compat.h): a light-sample pixel warped into the reference
// view by eq. 3 and its local depth plane (the splat, agrawala2000 §4 Precompute), and the display
// lookup of a view sample (agrawala2000 §4 Display) with the solid-object clamp. attenuation_map.cpp
// calls these functions; the GPU kernels (lam/kernels/) include this header. Layouts below are
// also the GPU's buffers (docs/methods/lam.md, "On the GPU").
//
// The finished map is read through two arrays:
//   layers  two floats per layer, (z, attenuation), each texel's layers nearest first;
//   ranges  texel t's layers are [ranges[t * stride], ranges[t * stride + 1]): the CPU's prefix
//           offsets (stride 1, texels + 1 entries), the GPU's (first, end) pairs (stride 2).
#ifndef PENUMBRA_SHADOW_LAM_LAM_SHARED_H
#define PENUMBRA_SHADOW_LAM_LAM_SHARED_H

#include "penumbra/core/shader_compat.h"

// Read-only uint arrays, as PN_FLOAT_ARRAY is for floats.
#ifdef __cplusplus
#define LAM_UINT_ARRAY const uint*
#else
#define LAM_UINT_ARRAY Uints
#endif

PN_SHARED_BEGIN

// The largest depth change per texel a surface's gradient may have, relative to depth: steeper
// than this (within a few degrees of edge-on) is clamped.
PN_CONST float kLamMaxSlope = 0.05f;
// The light's outline as the map holds it: disk and sphere lights as 16-gons.
PN_CONST int kLamMaxOutline = 16;
// What a texel's lookup returns besides an attenuation (>= 0).
PN_CONST float kLamOccluded = -1.0f;
PN_CONST float kLamUndefined = -2.0f;
// What the display returns, with LamMapView::unresolved on, for a point its texels do not resolve
// (lam_visibility): the caller traces that point's light samples instead (lam.cpp, lam_display.comp).
PN_CONST float kLamUnresolved = -3.0f;

// The reference view and the light as the display reads them (AttenuationMap's frame), 192 bytes:
//   bytes   0-47  the texel projection's rows 0-2 (world -> (X z, Y z, z)), each (vec3, offset)
//   bytes  48-63  near, far, width, height
//   bytes  64-79  eye, u0 (the window's left edge at unit depth)
//   bytes  80-95  right, v1 (its top edge)    96-111 up, delta (one texel at unit depth)
//   bytes 112-127 forward, epsilon (relative depth tolerance)
//   bytes 128-143 the light's centre, its outline's area
//   bytes 144-159 the outline's unit normal (counter-clockwise), its radius (slightly grown)
//   bytes 160-175 outline_count (points, <= kLamMaxOutline; 0: no solid clamp), slope (1: local
//                 planes), solid (1: the map clamps closed objects by front_fraction), empty (1: no
//                 layers at all: the shadow region was empty)
//   bytes 176-179 open_epsilon (the tolerance for open surfaces with local planes: lam_epsilon)
//   bytes 180-187 unresolved (1: the display returns kLamUnresolved where its texels do not resolve
//                 a point; 0: the paper's umbra and lit), trace_spread (the largest difference
//                 between the 4 texels' attenuations the bilinear display interpolates)
//   bytes 188-191 cap_tan (> 0: the shadow region was cut at |u|, |v| = cap_tan, and some caster's
//                 shadow reaches beyond it: with unresolved, the points there are traced; 0: not cut)
struct LamMapView {
  vec3 row0;
  float off0;
  vec3 row1;
  float off1;
  vec3 row2;
  float off2;
  float near;
  float far;
  int width;
  int height;
  vec3 eye;
  float u0;
  vec3 right;
  float v1;
  vec3 up;
  float delta;
  vec3 forward;
  float epsilon;
  vec3 light_center;
  float light_area;
  vec3 light_normal;
  float light_radius;
  uint outline_count;
  uint slope;
  uint solid;
  uint empty;
  float open_epsilon;
  uint unresolved;
  float trace_spread;
  float cap_tan;
};

// The tolerance within which two linear depths are one surface: epsilon * z (relative).
PN_INLINE float lam_depth_tolerance(float epsilon, float z) { return epsilon * z; }

// ---------------------------------------------------------------------------------------------
// Precompute: one pixel of a light sample's depth map (attenuation_map.cpp Builder).

// A warped depth-map pixel: the reference texel (ix, iy) whose centre is the top-left of the 4 it
// splats into, the depth carried to that texel's centre along the surface's local plane, the
// plane's depth gradient per reference texel (x, y), where the warped point lies between the 4
// centres (ax, ay in [0, 1): its bilinear weights) and the area of reference texels the pixel
// covers (the warp's Jacobian determinant; 1 without local planes).
struct LamSplat {
  int ix;
  int iy;
  float z00;
  float gx;
  float gy;
  float ax;
  float ay;
  float area;
};

// Eq. 3 for pixel (x, y) at linear depth z of the view of a sample displaced by (bx, by) texels at
// unit depth, whose texel-space origin lies (ox, oy) whole texels from the reference view's: the
// reference texel-space point minus 0.5 (fx, fy: the top-left splat centre) and its floor
// (ix, iy). False when the splat touches no texel of the W x H reference view.
PN_INLINE bool lam_warp(int x, int y, float z, int ox, int oy, float bx, float by, int W, int H, PN_OUT(float) fx,
                        PN_OUT(float) fy, PN_OUT(int) ix, PN_OUT(int) iy) {
  float inv = 1.0f / z;
  PN_PRECISE float wx = float(x) + 0.5f + float(ox) + bx * inv - 0.5f;
  PN_PRECISE float wy = float(y) + 0.5f + float(oy) - by * inv - 0.5f;
  fx = wx;
  fy = wy;
  ix = 0;
  iy = 0;
  if (!(fx >= -1.0f && fy >= -1.0f && fx < float(W) && fy < float(H))) return false;
  ix = int(fx + 1.0f) - 1;  // floor, for fx >= -1
  iy = int(fy + 1.0f) - 1;
  return true;
}

// Depth gradient along one image axis at a pixel from its two neighbours (zm at -1, zp at +1;
// +inf where empty or outside): central where both lie on the same surface, else the one-sided
// difference that does.
PN_INLINE float lam_axis_gradient(float zm, float z, float zp) {
  float jump = 4.0f * kLamMaxSlope * z;
  bool okm = abs(zm - z) <= jump;  // false for +inf
  bool okp = abs(zp - z) <= jump;
  float dm = z - zm;
  float dp = zp - z;
  if (okm && okp) {
    // A crease or a small step: the gentler side.
    if (abs(dm - dp) > 0.5f * (abs(dm) + abs(dp)) + 1e-6f * z) return abs(dm) < abs(dp) ? dm : dp;
    return 0.5f * (dm + dp);
  }
  if (okm) return dm;
  if (okp) return dp;
  return 0.0f;
}

// The splat of pixel (x, y) at depth z whose warp lam_warp gave (fx, fy, ix, iy): without local
// planes (slope false) its depth as is; with them, the surface's depth gradient in the sample view
// (from the neighbours' depths left, right, up and down) carried through the warp's Jacobian
// J = I + a g^T (a = (-bx, by) / z^2): per reference texel g / (1 + g.a), clamped, and the depth
// carried to the centre of texel (ix, iy).
PN_INLINE LamSplat lam_splat(float z, float zl, float zr, float zu, float zd, float bx, float by, float fx, float fy,
                             int ix, int iy, bool slope) {
  LamSplat s;
  s.ix = ix;
  s.iy = iy;
  s.z00 = z;
  s.gx = 0.0f;
  s.gy = 0.0f;
  PN_PRECISE float ax = fx - float(ix);
  PN_PRECISE float ay = fy - float(iy);
  s.ax = ax;
  s.ay = ay;
  s.area = 1.0f;
  if (!slope) return s;
  float inv = 1.0f / z;
  float sgx = lam_axis_gradient(zl, z, zr);
  float sgy = lam_axis_gradient(zu, z, zd);
  PN_PRECISE float den = 1.0f + (-bx * sgx + by * sgy) * inv * inv;
  s.area = max(den, 0.2f);
  float rden = 1.0f / s.area;
  float cap = kLamMaxSlope * z;
  s.gx = clamp(sgx * rden, -cap, cap);
  s.gy = clamp(sgy * rden, -cap, cap);
  PN_PRECISE float z00 = z - s.gx * (fx - float(ix)) - s.gy * (fy - float(iy));
  s.z00 = z00;
  return s;
}

// The splat's depth at the centre of texel (ix + i, iy + j), i and j in {0, 1}: as the CPU's
// insertion sums it (the row first, then the column).
PN_INLINE float lam_splat_depth(LamSplat s, int i, int j) {
  PN_PRECISE float row = j != 0 ? s.z00 + s.gy : s.z00;
  PN_PRECISE float z = i != 0 ? row + s.gx : row;
  return z;
}

// ---------------------------------------------------------------------------------------------
// Counting a layer (penumbra's addition to agrawala2000 §4, line 6, for open surfaces).
//
// The paper counts a (texel, layer) once per light sample that splats into it: a pixel counts at
// all 4 texels around its warped point. Where a sample sees a surface through gaps a texel or two
// wide (a ground in a canopy's dappled shade) that counts each gap up to 4 times over: the forest's
// ground read 0.033 too bright (docs/methods/lam.md, "Weighted splats"). So a layer
// of an open surface (flat per triangle: its local plane, and so the warp's Jacobian, is exact)
// adds each splat's share of the texel instead, its bilinear weight times the area of reference
// texels its pixel covers: a surface a sample sees whole adds about 1 at every texel, one seen
// through a gap its part. The sums per sample are not capped (two sampling grids beating give each
// texel a little more or less than 1; the excess and the deficit average out over the samples), and
// the layer's count is divided by the largest one sample gave it: a surface narrower than a texel
// (a hair strand) covers only part of its texels in every sample that sees it, and is still lit
// where every sample sees it. A closed object's layers keep the paper's count (its curved faces'
// splats are too uneven for weights: the bunny's own surface read 0.063 instead of 0.041).

// The weight splat s adds at texel (ix + i, iy + j).
PN_INLINE float lam_splat_weight(LamSplat s, int i, int j) {
  float wx = i != 0 ? s.ax : 1.0f - s.ax;
  float wy = j != 0 ? s.ay : 1.0f - s.ay;
  PN_PRECISE float w = wx * wy * s.area;
  return w;
}

// Once a light sample's splats into a texel are all in: a weighted layer adds that sample's weight
// to its count and keeps the largest (count, peak), and is ready for the next sample (weight 0).
// A weight within 1e-4 of 1 is 1: a sample that sees a plane facing it whole gives each texel
// bilinear weights that sum to 1 up to rounding, and such a texel is then lit exactly (1, as the
// paper's count gives it), not 0.99999994.
PN_CONST float kLamWholeTexel = 1e-4f;
PN_INLINE void lam_flush_layer(PN_INOUT(float) count, PN_INOUT(float) weight, PN_INOUT(float) peak) {
  float w = abs(weight - 1.0f) <= kLamWholeTexel ? 1.0f : weight;
  PN_PRECISE float c = count + w;
  count = c;
  peak = max(peak, w);
  weight = 0.0f;
}

// A layer's attenuation from what the samples added (count over `samples` light samples; peak: the
// most one sample added, or < 0 for a layer counted once per sample).
PN_INLINE float lam_layer_attenuation(float count, float peak, float inv_samples) {
  PN_PRECISE float a = count * inv_samples;
  if (peak >= 0.0f) a = a / max(min(peak, 1.0f), 1e-3f);
  return min(1.0f, a);
}

// ---------------------------------------------------------------------------------------------
// Display (agrawala2000 §4: the paper uses hardware texturing for the display).

// The lookup in one texel's layers [b, e) (sorted by depth): the attenuation of the layer nearest
// to z within tol (>= 0); kLamOccluded if none matches but one lies in front of z; kLamUndefined
// if none lies at or in front of z.
PN_INLINE float lam_lookup(PN_FLOAT_ARRAY layers, uint b, uint e, float z, float tol) {
  float best = tol;
  float result = kLamUndefined;
  for (uint l = b; l < e; ++l) {
    float lz = PN_AT(layers, 2u * l);
    float d = abs(lz - z);
    if (d <= best) {
      best = d;
      result = PN_AT(layers, 2u * l + 1u);
    } else if (lz < z) {
      result = kLamOccluded;  // in front (a later match overrides it)
    } else {
      break;  // behind z beyond the best match: no later layer can be nearer
    }
  }
  return result;
}

// lam_lookup in texel t's layers.
PN_INLINE float lam_lookup_texel(PN_FLOAT_ARRAY layers, LAM_UINT_ARRAY ranges, uint stride, uint t, float z,
                                 float epsilon) {
  return lam_lookup(layers, PN_AT(ranges, t * stride), PN_AT(ranges, t * stride + 1u), z,
                    lam_depth_tolerance(epsilon, z));
}

// One row of the texel projection applied to d = p - eye (LightView::texel_projection), summed as
// the CPU sums it.
PN_INLINE float lam_row(vec3 row, float off, vec3 d) {
  PN_PRECISE float h = row.x * d.x + row.y * d.y + row.z * d.z + off;
  return h;
}

// The depth of p's plane (the plane through p with normal n; nd, nr, nu, nf below) on the ray
// through texel-space point (cx, cy), clamped to z +- cap; p's own depth where the plane is not
// used or turns edge-on in between (den_p: the plane's denominator at p).
PN_INLINE float lam_plane_depth(bool plane, float nd, float nr, float nu, float nf, float den_p, float z, float cap,
                                float cx, float cy) {
  if (!plane) return z;
  PN_PRECISE float den = nr * cx - nu * cy + nf;
  if (!(den * den_p > 0.0f)) return z;
  return clamp(nd / den, z - cap, z + cap);
}

// The depth tolerance of a point on a closed object's surface or not: with local planes (penumbra's
// addition) an open surface (a leaf, a card, a ground plane: flat per triangle, its depth carried
// exactly along its plane) gets open_epsilon, which keeps the leaves of a crown apart; a closed
// object's curved faces keep epsilon. Without local planes every surface gets epsilon (the paper's
// rule). Insertion uses the same choice for the surface a splat came from.
PN_INLINE float lam_epsilon(LamMapView m, bool closed) { return m.slope != 0u && !closed ? m.open_epsilon : m.epsilon; }

// Visibility of world point p with geometric normal n (agrawala2000 §4, Display;
// AttenuationMap::visibility): project into the reference view; per texel, the layer within
// epsilon of p's depth gives its attenuation (with local planes, p's depth is first carried along
// the plane through p with normal n to the texel's centre, where the layers' depths are; n = 0
// skips that); no matching layer but one in front: umbra (0); no layer in front either: lit (1).
// Bilinear weighs the 4 texels around p, skipping those without a layer at or in front of p.
// Outside the shadow region: 1. `texels` counts the texels read.
// With m.unresolved (penumbra's addition; lam.md "Points the LDI does not resolve"), a point whose
// texels do not all hold its surface (nearest: the one texel; bilinear: each of the 4), or whose 4
// attenuations differ by more than m.trace_spread (a shadow detail finer than the texels), gets
// kLamUnresolved instead: the caller traces its light samples.
PN_INLINE float lam_visibility(PN_FLOAT_ARRAY layers, LAM_UINT_ARRAY ranges, uint stride, LamMapView m, vec3 p,
                               vec3 n, float epsilon, bool bilinear, bool slope, PN_INOUT(uint) texels) {
  vec3 d = p - m.eye;
  float z = lam_row(m.row2, m.off2, d);
  if (!(z >= m.near && z <= m.far)) return 1.0f;
  float inv = 1.0f / z;
  PN_PRECISE float x = lam_row(m.row0, m.off0, d) * inv;
  PN_PRECISE float y = lam_row(m.row1, m.off1, d) * inv;
  if (!(x >= 0.0f && y >= 0.0f && x < float(m.width) && y < float(m.height))) return 1.0f;
  // p's surface as a plane in the reference view: linear depth on the ray through texel point
  // (X, Y) is nd / (nr X - nu Y + nf) (u = u0 + X delta, v = v1 - Y delta). The layers hold depths
  // at texel centres, so p's depth is carried to the same centres.
  float nd = 0.0f;
  float nr = 0.0f;
  float nu = 0.0f;
  float nf = 0.0f;
  float den_p = 0.0f;
  bool plane = false;
  if (slope) {
    nd = dot(n, p - m.eye);
    nr = dot(n, m.right) * m.delta;
    nu = dot(n, m.up) * m.delta;
    PN_PRECISE float f = dot(n, m.forward) + dot(n, m.right) * m.u0 + dot(n, m.up) * m.v1;
    nf = f;
    PN_PRECISE float dp = nr * x - nu * y + nf;
    den_p = dp;
    plane = den_p != 0.0f;  // false for n = 0 too
  }
  float cap = 2.0f * kLamMaxSlope * z;
  if (!bilinear) {
    int ix = min(int(x), m.width - 1);
    int iy = min(int(y), m.height - 1);
    texels += 1u;
    float zt = lam_plane_depth(plane, nd, nr, nu, nf, den_p, z, cap, float(ix) + 0.5f, float(iy) + 0.5f);
    float r = lam_lookup_texel(layers, ranges, stride, uint(iy) * uint(m.width) + uint(ix), zt, epsilon);
    if (r < 0.0f && m.unresolved != 0u) return kLamUnresolved;
    return r >= 0.0f ? r : (r == kLamOccluded ? 0.0f : 1.0f);
  }
  // Bilinear over the 4 texel centres around p (percentage-closer style, agrawala2000 §6.1);
  // texels that p's surface does not reach (undefined) drop out of the weights.
  float fx = x - 0.5f;
  float fy = y - 0.5f;  // >= -0.5
  int x0 = int(fx + 1.0f) - 1;
  int y0 = int(fy + 1.0f) - 1;
  float wx = fx - float(x0);
  float wy = fy - float(y0);
  float sum = 0.0f;
  float wsum = 0.0f;
  uint matched = 0u;  // taps that hold p's surface, and the range of their attenuations
  float lo = 1.0f;
  float hi = 0.0f;
  for (int k = 0; k < 4; ++k) {
    int tx = x0 + (k & 1);
    int ty = y0 + (k >> 1);
    float w = ((k & 1) != 0 ? wx : 1.0f - wx) * ((k >> 1) != 0 ? wy : 1.0f - wy);
    if (tx < 0 || ty < 0 || tx >= m.width || ty >= m.height) continue;
    texels += 1u;
    float zt = lam_plane_depth(plane, nd, nr, nu, nf, den_p, z, cap, float(tx) + 0.5f, float(ty) + 0.5f);
    float r = lam_lookup_texel(layers, ranges, stride, uint(ty) * uint(m.width) + uint(tx), zt, epsilon);
    if (r >= 0.0f) {
      sum += w * r;
      wsum += w;
      matched += 1u;
      lo = min(lo, r);
      hi = max(hi, r);
    } else if (r == kLamOccluded) {
      wsum += w;
    }
  }
  if (m.unresolved != 0u && (matched < 4u || hi - lo > m.trace_spread)) return kLamUnresolved;
  return wsum > 0.0f ? sum / wsum : 1.0f;
}

// Point i of the outline (three floats a point).
PN_INLINE vec3 lam_outline_point(PN_FLOAT_ARRAY outline, uint i) {
  return vec3(PN_AT(outline, 3u * i), PN_AT(outline, 3u * i + 1u), PN_AT(outline, 3u * i + 2u));
}

// One vertex of the clipped outline into the fan area around the light centre.
PN_INLINE void lam_fan_vertex(vec3 v, vec3 c, vec3 normal, PN_INOUT(float) area, PN_INOUT(vec3) first,
                              PN_INOUT(vec3) prev, PN_INOUT(bool) have) {
  if (have)
    area += dot(normal, cross(prev - c, v - c));
  else
    first = v;
  prev = v;
  have = true;
}

// The fraction of the light's area in front of the plane through p with unit normal n (1 for
// n = 0; AttenuationMap::front_fraction): on a closed mesh the solid lies behind that plane, so the
// light behind it is hidden.
PN_INLINE float lam_front_fraction(PN_FLOAT_ARRAY outline, LamMapView m, vec3 p, vec3 n) {
  if (m.outline_count == 0u || !(dot(n, n) > 0.0f)) return 1.0f;
  // Quick exits: the plane misses the light's bounding sphere (n is unit length).
  float sc = dot(n, m.light_center - p);
  if (sc >= m.light_radius) return 1.0f;
  if (sc <= -m.light_radius) return 0.0f;
  uint count = min(m.outline_count, uint(kLamMaxOutline));
  float side[kLamMaxOutline];
  uint front = 0u;
  for (uint i = 0u; i < count; ++i) {
    side[i] = dot(n, lam_outline_point(outline, i) - p);
    if (side[i] > 0.0f) front += 1u;
  }
  if (front == count) return 1.0f;
  if (front == 0u) return 0.0f;
  // Area of the outline clipped to the front half-space (Sutherland-Hodgman, one plane), as a fan
  // around the light centre.
  float area = 0.0f;
  vec3 first = vec3(0.0f);
  vec3 prev = vec3(0.0f);
  bool have = false;
  for (uint i = 0u; i < count; ++i) {
    uint j = (i + 1u) % count;
    vec3 a = lam_outline_point(outline, i);
    if (side[i] > 0.0f) lam_fan_vertex(a, m.light_center, m.light_normal, area, first, prev, have);
    if ((side[i] > 0.0f) != (side[j] > 0.0f)) {
      vec3 b = lam_outline_point(outline, j);
      lam_fan_vertex(a + (b - a) * (side[i] / (side[i] - side[j])), m.light_center, m.light_normal, area, first, prev,
                     have);
    }
  }
  area += dot(m.light_normal, cross(prev - m.light_center, first - m.light_center));
  return clamp(0.5f * area / m.light_area, 0.0f, 1.0f);
}

// Whether p lies beyond the cut of the shadow region (m.cap_tan, fit_shadow_region's max_tan: 76
// degrees off the light's axis) where some caster's shadow reaches: the map holds nothing there, so
// with m.unresolved the point is traced (a street seen from far down its length under a high
// light: its points 73-82 degrees off the axis were counted lit). p behind the light's plane is
// the compose step's (V = 0).
PN_INLINE bool lam_beyond_cap(LamMapView m, vec3 p) {
  if (m.unresolved == 0u || !(m.cap_tan > 0.0f)) return false;
  vec3 d = p - m.eye;
  float z = dot(d, m.forward);
  float reach = m.cap_tan * z;
  return z > 0.0f && (abs(dot(d, m.right)) > reach || abs(dot(d, m.up)) > reach);
}

// A view sample's V from the map: lam_visibility, and on a solid object (the map's solid flag and
// the object closed) at most its front_fraction; kLamUnresolved beyond the region's cut.
PN_INLINE float lam_sample_visibility(PN_FLOAT_ARRAY layers, LAM_UINT_ARRAY ranges, uint stride,
                                      PN_FLOAT_ARRAY outline, LamMapView m, vec3 p, vec3 ng, bool closed,
                                      bool bilinear, PN_INOUT(uint) texels) {
  bool solid = m.solid != 0u && closed;
  if (lam_beyond_cap(m, p)) return kLamUnresolved;
  if (m.empty != 0u) return solid ? lam_front_fraction(outline, m, p, ng) : 1.0f;
  float v = lam_visibility(layers, ranges, stride, m, p, ng, lam_epsilon(m, closed), bilinear, m.slope != 0u, texels);
  return v > 0.0f && solid ? min(v, lam_front_fraction(outline, m, p, ng)) : v;
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::LamSplat) == 32);
static_assert(sizeof(penumbra::shader::LamMapView) == 192);
#endif

#endif  // PENUMBRA_SHADOW_LAM_LAM_SHARED_H
