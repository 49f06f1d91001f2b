// The shadow-map methods' per-sample math once for both devices, in the common subset of C++ and
// GLSL (core/shader_compat.h): a view sample as one map sees it (its receiver), the biased depth
// comparison, the transmittance of a texel, the hard lookup with its hoisted set-up, PCF
// (`shadow-map`), and PCSS's blocker search, penumbra estimate and filter (Fernando 2005) with
// xie2007 §3's variant (`pcss`). shadow_map_common.h's ShadowDepthMap and the CPU methods call
// these functions; the GPU kernels (shadow/baseline/kernels/) include this header, so both
// devices compute the same numbers (docs/methods/shadow-map.md and pcss.md state the rules).
// The map is read through its planes: z (linear depth, +inf where empty) and opacity, row-major,
// width x height (raster/depth_map.h; the GPU rasterizer writes the same planes).
#ifndef PENUMBRA_SHADOW_SHADOW_MAP_SHARED_H
#define PENUMBRA_SHADOW_SHADOW_MAP_SHARED_H

#include "penumbra/core/sampling_shared.h"
#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/raster_shared.h"
#include "penumbra/scene/light_shared.h"
#include "penumbra/shadow/near_field_shared.h"
#include "penumbra/trace/ray_shared.h"

PN_SHARED_BEGIN

// One map's view as the lookups need it, 176 bytes (scalar layout): bytes 0-159 the RasterView
// (raster/raster_shared.h), 160-163 focal (focal_texels: texels per unit of x/z), 164-167
// inv_focal (1 / focal), 168-171 z_min (the map's smallest depth, +inf when empty), 172-175 (0).
struct ShadowMapView {
  RasterView view;
  float focal;
  float inv_focal;
  float z_min;
  uint pad;
};

// shadow_map_common.h BiasParams, 16 bytes.
struct ShadowBias {
  float bias;
  float slope_bias;
  float max_slope;
  uint receiver_plane;
};

// A view sample as one map sees it (shadow_map_common.h Receiver).
struct ShadowReceiver {
  vec2 texel;  // its projection, texel space
  float z;     // its linear depth
  float s;     // world size of one texel at z
  // Linear-depth change of p's tangent plane per texel, in texel widths s (tan of the angle
  // between ng and the ray for a point on the view axis), clamped to max_slope.
  float slope;
  // The receiver plane: its depth along the ray through texel-space point (x, y) is
  // plane_num / (plane_a x + plane_b y + plane_c) (the denominator is dot(ng, ray dir)).
  float plane_num;  // dot(ng, p - eye)
  float plane_a;
  float plane_b;
  float plane_c;
  vec3 ng;
  vec3 p;      // the point (its coordinates' size bounds its rounding: sm_constant_bias)
  bool faces;  // dot(ng, eye - p) > 0
};

// Whether p is in front of the light's emitting plane (centre c, normal n): other points see
// nothing of the light's emitting side.
PN_INLINE bool sm_in_front_of_light(vec3 c, vec3 n, vec3 p) { return dot(p - c, n) > 0.0f; }

// Row `row` (offset `off`) of the texel projection applied to d = p - eye (LightView::
// texel_projection), summed as Mat4::transform_homogeneous sums it.
PN_INLINE float sm_row(vec3 row, float off, vec3 d) {
  PN_PRECISE float h = row.x * d.x + row.y * d.y + row.z * d.z + off;
  return h;
}

// The world size of one texel at linear depth z (LightView::texel_world_size at max(z, near)).
PN_INLINE float sm_texel_size(RasterView v, float z) { return (v.r - v.l) / float(v.width) * max(z, v.near) / v.near; }

// The constant depth bias of a receiver at linear depth z where one texel of the map is s wide:
// the `bias` parameter (world units; its defaults, 0.001 and 0.002, suit scenes about a unit
// large) kept within [kSmBiasFloor z, s], so that a scene means the same in any unit:
// - at least 64 float epsilons of the depth: below, a lit surface shadows itself from rounding
//   alone (a street modelled in millimetres lies 10^5 units from the light, where a float depth
//   is exact to 0.008: `shadow-map` drew acne over all of it, mean |dV| 0.06 against `hard`'s
//   0.0007; 16 epsilons still left acne on a few pixels at 3 x 10^5);
// - at most one texel: a larger bias lets light through occluders the map resolves (the bunny
//   scene at 1/100 of its size: `vsm` 0.017 -> 0.026, at 1/1000 `shadow-map` 0.031 -> 0.061).
// - at least the ray offset's share of p's largest coordinate (trace/ray_shared.h): p is exact to
//   a few ulps of its coordinates, not of its depth (a street 2 x 10^4 units from the world's
//   origin, 10 from its light: its points are exact to 0.002, and `shadow-map` drew acne on
//   every face the light grazes).
// The shipped scenes' pictures stayed the same bit for bit with the first two; the third, with
// the eye-relative projection, moved them by a mean |dV| of 2e-4 at most (docs/methods/
// shadow-map.md, "A scene in any unit", "A scene far from the origin").
PN_CONST float kSmBiasFloor = 64.0f * 1.1920929e-07f;
PN_INLINE float sm_constant_bias(float bias, float z, float s, vec3 p, float slope) {
  float position = ray_coordinate_rounding(p) * (1.0f + slope);
  return max(max(kSmBiasFloor * z, position), min(bias, s));
}

// ShadowDepthMap::receiver.
PN_INLINE ShadowReceiver sm_receiver(ShadowMapView m, vec3 p, vec3 ng, ShadowBias b) {
  RasterView v = m.view;
  ShadowReceiver r;
  // LightView::to_texel.
  vec3 d = p - v.eye;
  float w = sm_row(v.row3, v.off3, d);
  float tz = sm_row(v.row2, v.off2, d);
  r.texel = vec2(sm_row(v.row0, v.off0, d) / w, sm_row(v.row1, v.off1, d) / w);
  r.z = tz;
  r.s = sm_texel_size(v, tz);
  r.ng = ng;
  r.p = p;
  vec3 to_eye = v.eye - p;
  r.faces = dot(ng, to_eye) > 0.0f;
  r.plane_num = -dot(ng, to_eye);
  // dot(ng, texel_ray(x, y).dir) with dir = right u / near + up v / near + forward,
  // u = l + (r - l) x / W, v = t - (t - b) y / H (LightView::texel_ray).
  float nr = dot(ng, v.right) / v.near;
  float nu = dot(ng, v.up) / v.near;
  r.plane_a = nr * (v.r - v.l) / float(v.width);
  r.plane_b = -nu * (v.t - v.b) / float(v.height);
  r.plane_c = nr * v.l + nu * v.t + dot(ng, v.forward);
  // The tangent plane's linear depth along texel rays d(x, y) (unit forward component) is
  // plane_num / dot(ng, d); one texel moves d by right / f (or up / f), so the depth changes by
  // s * |(ng.right, ng.up)| / |ng.d| per texel. On the view axis that is tan(theta).
  float den = tz > 0.0f ? abs(dot(ng, (p - v.eye) * (1.0f / tz))) : 0.0f;
  float lateral = sqrt(dot(ng, v.right) * dot(ng, v.right) + dot(ng, v.up) * dot(ng, v.up));
  r.slope = lateral < b.max_slope * den ? lateral / den : b.max_slope;
  return r;
}

// The depth a surface at texel (x, y) must be in front of to block the receiver
// (ShadowDepthMap::reference_depth): slope-scaled bias, or the receiver plane.
PN_INLINE float sm_reference_depth(ShadowReceiver r, int x, int y, ShadowBias b) {
  float dx = float(x) + 0.5f - r.texel.x;
  float dy = float(y) + 0.5f - r.texel.y;
  float reach = max(1.0f, sqrt(dx * dx + dy * dy));
  float bias = sm_constant_bias(b.bias, r.z, r.s, r.p, r.slope);
  if (b.receiver_plane == 0u) return r.z - bias - b.slope_bias * r.s * r.slope * reach;
  float limit = b.max_slope * r.s * reach;
  float den = r.plane_a * (float(x) + 0.5f) + r.plane_b * (float(y) + 0.5f) + r.plane_c;
  // The ray meets the plane in front when den has the sign of plane_num (both negative for a
  // plane facing the eye); otherwise the plane is beyond its horizon: far away.
  float zp = den * r.plane_num > 0.0f ? r.plane_num / den : uintBitsToFloat(0x7f800000u);
  // Nothing behind p can block it (every point of a segment from p to the light is at most as
  // deep as p), however far the plane runs.
  return clamp(zp, r.z - limit, r.z) - bias;
}

// The fraction of light texel (x, y) lets through to a receiver whose reference depth there is
// `ref`: 1 outside the map or when its surface is not in front of ref, otherwise 1 - opacity.
PN_INLINE float sm_transmit(PN_FLOAT_ARRAY z, PN_FLOAT_ARRAY opacity, int width, int height, int x, int y,
                            float ref) {
  if (x < 0 || y < 0 || x >= width || y >= height) return 1.0f;
  uint i = uint(y) * uint(width) + uint(x);
  return PN_AT(z, i) < ref ? 1.0f - PN_AT(opacity, i) : 1.0f;
}

// The same at a texel-space point (its texel: the floor of the coordinates).
PN_INLINE float sm_transmit_at(PN_FLOAT_ARRAY z, PN_FLOAT_ARRAY opacity, ShadowMapView m, ShadowReceiver r,
                               vec2 texel, ShadowBias b) {
  int x = int(floor(texel.x));
  int y = int(floor(texel.y));
  if (x < 0 || y < 0 || x >= m.view.width || y >= m.view.height) return 1.0f;
  return sm_transmit(z, opacity, m.view.width, m.view.height, x, y, sm_reference_depth(r, x, y, b));
}

// The hard-shadow lookup of one point at its own texel (ShadowDepthMap::lookup): 0 when p lies
// on a closed object and does not face the eye, else sm_transmit_at(sm_receiver(p, ng), its
// texel). The same numbers as those calls, with the per-map set-up hoisted. `cut`: only a surface
// in front of this depth as well as of the biased reference depth blocks (+inf: the plain lookup;
// multi-view-sm's near field passes the depth where the map's answer begins, multi_view_shared.h).
PN_INLINE float sm_lookup_beyond(PN_FLOAT_ARRAY zs, PN_FLOAT_ARRAY opacity, ShadowMapView m, vec3 p, vec3 ng,
                                 bool closed, ShadowBias b, float cut) {
  if (b.receiver_plane != 0u) {
    ShadowReceiver r = sm_receiver(m, p, ng, b);
    if (!r.faces && closed) return 0.0f;
    int x = int(floor(r.texel.x));
    int y = int(floor(r.texel.y));
    if (x < 0 || y < 0 || x >= m.view.width || y >= m.view.height) return 1.0f;
    return sm_transmit(zs, opacity, m.view.width, m.view.height, x, y, min(sm_reference_depth(r, x, y, b), cut));
  }
  RasterView v = m.view;
  vec3 d = p - v.eye;
  float plane_num = dot(ng, d);
  if (!(plane_num < 0.0f) && closed) return 0.0f;  // faces: dot(ng, eye - p) > 0
  float z = dot(d, v.forward);
  float inv_z = 1.0f / z;
  float tx = sm_row(v.row0, v.off0, d) * inv_z;
  float ty = sm_row(v.row1, v.off1, d) * inv_z;
  if (!(tx >= 0.0f) || !(ty >= 0.0f) || !(tx < float(v.width)) || !(ty < float(v.height))) return 1.0f;
  uint i = uint(ty) * uint(v.width) + uint(tx);
  float zt = PN_AT(zs, i);
  // Cheap early out: a surface farther than p never blocks.
  if (!(zt < z)) return 1.0f;
  float nr = dot(ng, v.right);
  float nu = dot(ng, v.up);
  float lateral = sqrt(nr * nr + nu * nu);
  float den = abs(plane_num) * inv_z;
  float slope = lateral < b.max_slope * den ? lateral / den : b.max_slope;
  // Own texel: reach max(1, d_t) = 1; s = z / focal.
  float ref = z - sm_constant_bias(b.bias, z, z * m.inv_focal, p, slope) - b.slope_bias * z * m.inv_focal * slope;
  return zt < min(ref, cut) ? 1.0f - PN_AT(opacity, i) : 1.0f;
}

PN_INLINE float sm_lookup(PN_FLOAT_ARRAY zs, PN_FLOAT_ARRAY opacity, ShadowMapView m, vec3 p, vec3 ng, bool closed,
                          ShadowBias b) {
  return sm_lookup_beyond(zs, opacity, m, p, ng, closed, b, uintBitsToFloat(0x7f800000u));
}

// The near field of the segment from p to map m's eye (near_field_shared.h): its part where an
// occluder's penumbra at p would be narrower than `near_field` texels of the map at p's depth, for
// a light of width `light_width` (near_field_light_width). There the map draws a shadow coarser
// than the penumbra, and the methods with a near field trace that part of the ray instead
// (multi-view-sm: every light point's; vsm, evsm, msm: the light centre's). 0 with near_field 0.
PN_INLINE float sm_near_field_length(ShadowMapView m, vec3 p, float near_field, float light_width) {
  if (!(near_field > 0.0f)) return 0.0f;
  RasterView v = m.view;
  float z = dot(p - v.eye, v.forward);
  return near_field_length(near_field * sm_texel_size(v, z), length(v.eye - p), light_width);
}

// Whether a receiver lies outside the map: behind its near plane or beyond its window (not
// covered; it counts as lit).
PN_INLINE bool sm_outside(ShadowMapView m, vec3 p) {
  RasterView v = m.view;
  vec3 d = p - v.eye;
  float w = sm_row(v.row3, v.off3, d);
  float z = sm_row(v.row2, v.off2, d);
  float x = sm_row(v.row0, v.off0, d) / w;
  float y = sm_row(v.row1, v.off1, d) / w;
  return !(z >= v.near && x >= 0.0f && y >= 0.0f && x < float(v.width) && y < float(v.height));
}

// `shadow-map`'s visibility of one view sample (shadow/baseline/shadow_map.cpp): 0 behind the
// light's plane; otherwise percentage-closer filtering (Reeves et al. 1987) of the (2 pcf + 1)^2
// box of texels around the receiver's own, each texel compared with its own reference depth.
// `bilinear`: the box slides with the receiver between texel centres, i.e. it is convolved with
// a one-texel tent, as a depth-compare sampler with linear filtering does (pcf = 0: the 2 x 2
// texels around p weighted by its position, a one-texel ramp across every shadow edge instead
// of a step); where p sits on a texel centre that is the plain box. Not bilinear, pcf = 0: the
// one texel p falls in (the hard lookup). `texels` counts the texels read.
PN_INLINE float shadow_map_visibility(PN_FLOAT_ARRAY z, PN_FLOAT_ARRAY opacity, ShadowMapView m, ShadowBias b,
                                      int pcf, bool bilinear, vec3 light_center, vec3 light_n, vec3 p, vec3 ng,
                                      bool closed, PN_INOUT(uint) texels) {
  if (!sm_in_front_of_light(light_center, light_n, p)) return 0.0f;
  if (pcf == 0 && !bilinear) {
    texels += 1u;
    return sm_lookup(z, opacity, m, p, ng, closed, b);
  }
  ShadowReceiver rc = sm_receiver(m, p, ng, b);
  if (!rc.faces && closed) return 0.0f;
  // The texels [x0, x1] x [y0, y1]; with `bilinear` one more each way, the first weighted by
  // 1 - w and the last by w along each axis (w: p's offset past the texel centre before it).
  int x0, y0;
  float wx = 0.0f, wy = 0.0f;
  if (bilinear) {
    float fx = rc.texel.x - 0.5f;
    float fy = rc.texel.y - 0.5f;
    x0 = int(floor(fx));
    y0 = int(floor(fy));
    wx = fx - float(x0);
    wy = fy - float(y0);
  } else {
    x0 = int(floor(rc.texel.x));
    y0 = int(floor(rc.texel.y));
  }
  int last = bilinear ? pcf + 1 : pcf;
  float v = 0.0f;
  for (int dy = -pcf; dy <= last; ++dy) {
    float row_weight = !bilinear ? 1.0f : dy == -pcf ? 1.0f - wy : dy == last ? wy : 1.0f;
    float row = 0.0f;
    for (int dx = -pcf; dx <= last; ++dx) {
      float weight = !bilinear ? 1.0f : dx == -pcf ? 1.0f - wx : dx == last ? wx : 1.0f;
      int x = x0 + dx;
      int y = y0 + dy;
      row += weight * sm_transmit(z, opacity, m.view.width, m.view.height, x, y, sm_reference_depth(rc, x, y, b));
    }
    v += row_weight * row;
  }
  texels += uint((last + pcf + 1) * (last + pcf + 1));
  return v * (1.0f / float((2 * pcf + 1) * (2 * pcf + 1)));
}

// What PCSS needs of the light: its geometry, its sampling table where it is textured
// (AreaLight::sample_area warps u through it first; the tables are passed beside), and the
// radius xie2007's eq. 1 uses (AreaLight::extent_radius).
struct PcssLight {
  LightGeometry geometry;
  uint textured;
  int table_width;
  int table_height;
  float extent_radius;
};

// AreaLight::sample_area: the light point for u in [0,1)^2.
PN_INLINE vec3 pcss_light_point(PcssLight L, PN_FLOAT_ARRAY marginal, PN_FLOAT_ARRAY conditional, vec2 u) {
  if (L.textured != 0u) u = piecewise_constant_2d_sample(marginal, conditional, L.table_width, L.table_height, u);
  return light_sample_area(L.geometry, u);
}

// Cranley-Patterson rotation: a toroidal shift keeps the stratification.
PN_INLINE vec2 pcss_rotate(vec2 u, vec2 shift) {
  u = u + shift;
  if (u.x >= 1.0f) u.x -= 1.0f;
  if (u.y >= 1.0f) u.y -= 1.0f;
  return u;
}

// Where a light point q lands in a map from the light's centre, per unit of
// (1/z_blocker - 1/z_receiver) (shadow_map_common.h kernel_offset: the PCSS kernel, Fernando
// 2005; xie2007 eq. 1 for a disk).
PN_INLINE vec2 sm_kernel_offset(ShadowMapView m, vec3 q) {
  vec3 d = q - m.view.eye;
  return vec2(m.focal * dot(d, m.view.right), -m.focal * dot(d, m.view.up));
}

// Point i of a kernel of stratified points on [0,1)^2 (LightSampleSet::base, two floats each).
PN_INLINE vec2 pcss_base(PN_FLOAT_ARRAY base, int i) {
  return vec2(PN_AT(base, uint(2 * i)), PN_AT(base, uint(2 * i + 1)));
}

// xie2007 eq. 1 (shadow_map_common.h xie2007_filter_size): the radius in texels of the region
// around a receiver's texel where blockers of a light of radius `light_radius` can lie.
PN_INLINE float sm_xie2007_filter_size(float focal, float light_radius, float z_min, float pz) {
  if (!(pz > z_min) || !(z_min > 0.0f)) return 0.0f;
  return focal * light_radius * (1.0f / z_min - 1.0f / pz);
}

// PCSS's visibility of one view sample (shadow/baseline/pcss.cpp; the steps are its header's).
// fernando (xie2007 = 0):
//  1. blocker search over the light's shape projected through p onto the map's smallest depth:
//     `blocker_samples` light points, a texel blocks when its depth is in front of p's reference
//     depth there; d_b = the blockers' mean depth (Fernando 2005);
//  2. penumbra estimate: the light's shape scaled by (1/d_b - 1/z_p);
//  3. PCF over `pcf_samples` light points q looked up at texel(p) + kernel_offset(q) * scale.
//  On a closed object, light points behind p's own surface count as blocked.
// xie2007 (§3, eq. 1): no blocker search; `pcf_samples` points in the disk of radius
//  filter_size around p's texel, V = the mean transmittance.
// Both kernels are rotated by `shift` (Cranley-Patterson; 0 without jitter). `texels` counts the
// texels read; `no_blocker` says the blocker search found none (fernando).
PN_INLINE float pcss_visibility(PN_FLOAT_ARRAY zs, PN_FLOAT_ARRAY opacity, ShadowMapView m, ShadowBias b,
                                PcssLight L, PN_FLOAT_ARRAY marginal, PN_FLOAT_ARRAY conditional,
                                PN_FLOAT_ARRAY blocker_base, int blocker_samples, PN_FLOAT_ARRAY pcf_base,
                                int pcf_samples, uint xie2007, vec2 shift, vec3 p, vec3 ng, bool closed,
                                PN_INOUT(uint) texels, PN_OUT(bool) no_blocker) {
  no_blocker = false;
  if (!sm_in_front_of_light(L.geometry.center, L.geometry.n, p)) return 0.0f;
  ShadowReceiver rc = sm_receiver(m, p, ng, b);
  float z_min = m.z_min;
  if (xie2007 != 0u) {
    if (!rc.faces && closed) return 0.0f;
    float radius = sm_xie2007_filter_size(m.focal, L.extent_radius, z_min, rc.z);
    float v = 0.0f;
    for (int i = 0; i < pcf_samples; ++i) {
      vec2 d = concentric_disk(pcss_rotate(pcss_base(pcf_base, i), shift));
      v += sm_transmit_at(zs, opacity, m, rc, rc.texel + d * radius, b);
    }
    texels += uint(pcf_samples);
    return v / float(pcf_samples);
  }
  // 1. Blocker search over the light's shape projected onto z_min.
  float search = rc.z > z_min ? 1.0f / z_min - 1.0f / rc.z : 0.0f;
  double sum = double(0.0f);
  int count = 0;
  for (int i = 0; i < blocker_samples; ++i) {
    vec3 q = pcss_light_point(L, marginal, conditional, pcss_rotate(pcss_base(blocker_base, i), shift));
    if (closed && dot(ng, q - p) <= 0.0f) continue;
    vec2 t = rc.texel + sm_kernel_offset(m, q) * search;
    int x = int(floor(t.x));
    int y = int(floor(t.y));
    texels += 1u;
    if (x < 0 || y < 0 || x >= m.view.width || y >= m.view.height) continue;
    float z = PN_AT(zs, uint(y) * uint(m.view.width) + uint(x));
    if (z < sm_reference_depth(rc, x, y, b)) {
      sum += double(z);
      ++count;
    }
  }
  // 2. Penumbra estimate: the light's shape scaled by (1/d_b - 1/z_p).
  float scale = count > 0 ? max(0.0f, 1.0f / float(sum / double(count)) - 1.0f / rc.z) : 0.0f;
  no_blocker = count == 0;
  // 3. PCF over that kernel (with no blocker, only p's own horizon darkens it).
  float v = 0.0f;
  for (int i = 0; i < pcf_samples; ++i) {
    vec3 q = pcss_light_point(L, marginal, conditional, pcss_rotate(pcss_base(pcf_base, i), shift));
    if (closed && dot(ng, q - p) <= 0.0f) continue;
    if (count == 0) {
      v += 1.0f;
      continue;
    }
    v += sm_transmit_at(zs, opacity, m, rc, rc.texel + sm_kernel_offset(m, q) * scale, b);
    texels += 1u;
  }
  return v / float(pcf_samples);
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::ShadowMapView) == 176);
static_assert(sizeof(penumbra::shader::ShadowBias) == 16);
#endif

#endif  // PENUMBRA_SHADOW_SHADOW_MAP_SHARED_H
