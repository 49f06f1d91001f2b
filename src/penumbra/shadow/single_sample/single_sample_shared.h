// parker1998's outer objects once for both devices, in the common subset of C++ and GLSL
// (core/shader_compat.h): the falloff and its inverse, the analytic sphere, a triangle's and a
// box's distance from a shadow ray in cone space, the plane test that prunes them, and what one
// occluder does to a ray's light. outer_objects.h and single_sample.cpp call these functions (the
// CPU keeps its SIMD versions of the triangle and box tests beside them); the GPU's search
// (kernels/single_sample_search.comp) includes this header. The structs below are also the GPU's
// buffers, byte for byte the CPU's (static_asserts in single_sample_gpu.cpp).
#ifndef PENUMBRA_SHADOW_SINGLE_SAMPLE_SINGLE_SAMPLE_SHARED_H
#define PENUMBRA_SHADOW_SINGLE_SAMPLE_SINGLE_SAMPLE_SHARED_H

#include "penumbra/core/shader_compat.h"

#ifdef __cplusplus
#include <cmath>
#endif

PN_SHARED_BEGIN

#ifdef __cplusplus
inline float ss_asin(float x) { return std::asin(x); }
#else
float ss_asin(float x) {
  float a = pn_asin_positive(abs(x));
  return x < 0.0f ? -a : a;
}
#endif

// A triangle of the occluder BVH, 48 bytes (trace/bvh.h BvhTriangle): its corners (in the light
// frame), its object and triangle, its opacity (material x triangle x mean alpha).
struct SsTriangle {
  vec3 v0;
  vec3 v1;
  vec3 v2;
  uint object;
  uint prim;
  float opacity;
};

// A node of the occluder BVH, 32 bytes (trace/bvh.h BvhNode): its box; an inner node's children
// at first and first + 1 (count 0), a leaf's triangles [first, first + count).
struct SsNode {
  vec3 lo;
  vec3 hi;
  uint first;
  uint count;
};

// A triangle's plane, 16 bytes: unit normal n, dot(n, x) = d on it (zero and +inf for a triangle
// without area).
struct SsPlane {
  vec3 n;
  float d;
};

// An object kept as parker1998's analytic sphere (world space), 24 bytes.
struct SsSphere {
  vec3 center;
  float radius;
  uint object;
  float opacity;
};

// parker1998 appendix: s = 3 tau^2 - 2 tau^3, the Bernstein cubic with the values and slopes of
// the sinusoid (1 + sin(pi tau - pi/2)) / 2 at tau = 0 and 1. s is the light that passes: 0 at
// the inner (real) surface, 1 at the outer object's boundary.
PN_INLINE float ss_falloff(float tau) {
  tau = clamp(tau, 0.0f, 1.0f);
  return tau * tau * (3.0f - 2.0f * tau);
}

// The inverse of ss_falloff on [0,1]: tau = 1/2 - sin(asin(1 - 2s) / 3).
PN_INLINE float ss_inverse_falloff(float s) {
  s = clamp(s, 0.0f, 1.0f);
  return 0.5f - pn_sin(ss_asin(1.0f - 2.0f * s) / 3.0f);
}

// parker1998 appendix, sphere (centre c, radius R) and a shadow ray p = o + t v (unit v) toward a
// light of diameter D at distance light_dist from o.
PN_INLINE float ss_sphere_transmission(vec3 o, vec3 v, float light_dist, vec3 c, float R, float D) {
  float t0 = dot(c - o, v);
  if (t0 < 0.0f || t0 > light_dist) return 1.0f;  // behind the point, or beyond the light
  float b = D * t0 / light_dist;                  // penumbra width at the occluder: b = a D / A
  float d = length(o + v * t0 - c);               // distance from c to the ray
  if (d < R) return 0.0f;
  if (d > R + b) return 1.0f;
  return ss_falloff((d - R) / b);
}

// A point of a polygon in the ray's frame: along the ray (t) and across it (x, y).
struct SsRayPoint {
  float t;
  float x;
  float y;
};

// A convex polygon of at most 5 points (a triangle clipped by two planes).
struct SsPolygon {
  SsRayPoint p[5];
  int n;
};

// Clips the polygon to t >= bound (sign = +1) or t <= bound (sign = -1).
PN_INLINE SsPolygon ss_clip(SsPolygon in_poly, float bound, float sign) {
  SsPolygon out_poly;
  out_poly.n = 0;
  for (int i = 0; i < in_poly.n; ++i) {
    SsRayPoint p = in_poly.p[i];
    SsRayPoint q = in_poly.p[(i + 1) % in_poly.n];
    float dp = sign * (p.t - bound);
    float dq = sign * (q.t - bound);
    if (dp >= 0.0f) out_poly.p[out_poly.n++] = p;
    if ((dp >= 0.0f) != (dq >= 0.0f)) {
      float s = dp / (dp - dq);
      SsRayPoint r;
      r.t = p.t + s * (q.t - p.t);
      r.x = p.x + s * (q.x - p.x);
      r.y = p.y + s * (q.y - p.y);
      out_poly.p[out_poly.n++] = r;
    }
  }
  return out_poly;
}

// Squared distance from the origin to the convex polygon q[0..n) of the plane t = 1 (0 when the
// origin is inside; a polygon of zero area has no inside).
PN_INLINE float ss_polygon_distance2(vec2 q[5], int n) {
  bool pos = false;
  bool neg = false;
  float best2 = uintBitsToFloat(0x7f800000u);
  for (int i = 0; i < n; ++i) {
    vec2 p = q[i];
    vec2 e = q[i + 1 == n ? 0 : i + 1] - q[i];
    float side = e.x * (0.0f - p.y) - e.y * (0.0f - p.x);  // cross(e, origin - p)
    pos = pos || side > 0.0f;
    neg = neg || side < 0.0f;
    float len2 = e.x * e.x + e.y * e.y;
    float s = len2 > 0.0f ? clamp(-(p.x * e.x + p.y * e.y) / len2, 0.0f, 1.0f) : 0.0f;
    vec2 closest = p + e * s;
    best2 = min(best2, closest.x * closest.x + closest.y * closest.y);
  }
  // The axis passes through the triangle (or its edge).
  if (pos != neg) return 0.0f;
  return best2;
}

// Whether every corner of triangle (a, b, c) lies within [near, far] along the ray o + t v (the
// common case of ss_triangle_cone_distance2; the others are clipped).
PN_INLINE bool ss_triangle_in_range(vec3 o, vec3 v, float near, float far, vec3 a, vec3 b, vec3 c) {
  float ta = dot(a - o, v);
  float tb = dot(b - o, v);
  float tc = dot(c - o, v);
  return min(ta, min(tb, tc)) >= near && max(ta, max(tb, tc)) <= far;
}

// The triangle (a, b, c)'s outer object distance from the ray o + t v, squared (outer_objects.h
// triangle_cone_distance2): the smallest (perp / t)^2 over its points with near <= t <= far, the
// 2D distance from the axis to the triangle projected perspectively from o onto t = 1. (e1, e2, v)
// is an orthonormal frame around the ray. +inf when no part lies in [near, far].
PN_INLINE float ss_triangle_cone_distance2(vec3 o, vec3 v, vec3 e1, vec3 e2, float near, float far, vec3 a, vec3 b,
                                           vec3 c) {
  SsPolygon poly;
  poly.n = 3;
  vec3 r = a - o;
  poly.p[0].t = dot(r, v);
  poly.p[0].x = dot(r, e1);
  poly.p[0].y = dot(r, e2);
  r = b - o;
  poly.p[1].t = dot(r, v);
  poly.p[1].x = dot(r, e1);
  poly.p[1].y = dot(r, e2);
  r = c - o;
  poly.p[2].t = dot(r, v);
  poly.p[2].x = dot(r, e1);
  poly.p[2].y = dot(r, e2);
  vec2 q[5];
  float t_min = min(poly.p[0].t, min(poly.p[1].t, poly.p[2].t));
  float t_max = max(poly.p[0].t, max(poly.p[1].t, poly.p[2].t));
  if (t_min >= near && t_max <= far) {
    // The common case: the whole triangle lies in [near, far] along the ray. Perspective
    // projection onto the plane t = 1; the ray's axis is the origin.
    for (int i = 0; i < 3; ++i) {
      float inv = 1.0f / poly.p[i].t;
      q[i] = vec2(poly.p[i].x * inv, poly.p[i].y * inv);
    }
    return ss_polygon_distance2(q, 3);
  }
  poly = ss_clip(poly, near, 1.0f);
  if (poly.n < 3) return uintBitsToFloat(0x7f800000u);
  poly = ss_clip(poly, far, -1.0f);
  if (poly.n < 3) return uintBitsToFloat(0x7f800000u);
  for (int i = 0; i < poly.n; ++i) q[i] = vec2(poly.p[i].x / poly.p[i].t, poly.p[i].y / poly.p[i].t);
  return ss_polygon_distance2(q, poly.n);
}

// Lower bound of (perp / t)^2 over the points of the box [lo, hi] with near <= t <= far for the
// ray o + t v with frame (e1, e2) (av, ae1, ae2: their component-wise absolute values): the box's
// extent across the ray gives the smallest distance from the axis, over the largest t.
PN_INLINE float ss_box_bound2(vec3 lo, vec3 hi, vec3 o, vec3 v, vec3 e1, vec3 e2, vec3 av, vec3 ae1, vec3 ae2,
                              float near, float far) {
  vec3 c = (lo + hi) * 0.5f - o;
  vec3 h = (hi - lo) * 0.5f;
  float tc = dot(c, v);
  float th = dot(h, av);
  float tmax = min(tc + th, far);
  if (tmax <= near || tc - th >= far) return uintBitsToFloat(0x7f800000u);
  float dx = max(0.0f, abs(dot(c, e1)) - dot(h, ae1));
  float dy = max(0.0f, abs(dot(c, e2)) - dot(h, ae2));
  return (dx * dx + dy * dy) / (tmax * tmax);
}

// True when no point of the plane is nearer than limit2 to the ray o + t v in cone space: the
// ray's origin lies on one side and the ray leaves the plane (n . v >= 0, n toward the origin's
// side), so every point of the plane is seen at least asin(n . v) off the ray: perp / t >=
// tan(asin(n . v)) >= n . v.
PN_INLINE bool ss_leaves_plane(vec3 o, vec3 v, SsPlane plane, float limit2) {
  float side = dot(plane.n, o) - plane.d;
  float nv = dot(plane.n, v);
  if (side < 0.0f) nv = -nv;
  return nv >= 0.0f && nv * nv >= limit2;
}

// The light a triangle of opacity `opacity` at squared cone distance d2 lets through a ray whose
// cone has (D / |l - o|)^2 = k2: 1 - opacity (1 - falloff(tau)), tau = sqrt(d2 / k2).
PN_INLINE float ss_occluder_transmission(float opacity, float d2, float k2) {
  return 1.0f - opacity * (1.0f - ss_falloff(sqrt(d2 / k2)));
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::SsTriangle) == 48);
static_assert(sizeof(penumbra::shader::SsNode) == 32);
static_assert(sizeof(penumbra::shader::SsPlane) == 16);
static_assert(sizeof(penumbra::shader::SsSphere) == 24);
#endif

#endif  // PENUMBRA_SHADOW_SINGLE_SAMPLE_SINGLE_SAMPLE_SHARED_H
