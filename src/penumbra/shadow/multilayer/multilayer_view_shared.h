// The per-receiver steps of the multilayer maps' light-centre view (multilayer_map.h:
// caster_boxes, shadowable_receivers, light_centre_view; xie2007 eq. 4) in the common subset of
// C++ and GLSL (core/shader_compat.h). The CPU runs them over its receivers; the GPU runs them
// over the view samples on the device and reduces (kernels/multilayer_fit.comp), and both build
// the view with the same host code.
#ifndef PENUMBRA_SHADOW_MULTILAYER_MULTILAYER_VIEW_SHARED_H
#define PENUMBRA_SHADOW_MULTILAYER_MULTILAYER_VIEW_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// A view sample at p is a receiver of the light (center, normal n) when it lies in front of the
// light's plane.
PN_INLINE bool ml_is_receiver(vec3 center, vec3 n, vec3 p) { return dot(p - center, n) > 0.0f; }

// A planar object (the plane dot(n, x) = d) can shadow a receiver only if the receiver lies on
// the other side of it than (part of) the light: `side` is the light centre's signed distance,
// `tol` the tolerance (caster_boxes).
PN_INLINE bool ml_behind_plane(vec3 n, float d, float side, float tol, vec3 p) { return (dot(n, p) - d) * side < tol; }

// core/math.h coordinate_system (Duff et al.'s branchless frame), copysign written out.
PN_INLINE void ml_coordinate_system(vec3 n, PN_OUT(vec3) t, PN_OUT(vec3) b) {
  float sign = (floatBitsToUint(n.z) & 0x80000000u) != 0u ? -1.0f : 1.0f;
  float a = -1.0f / (sign + n.z);
  float c = n.x * n.y * a;
  t = vec3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
  b = vec3(c, sign + n.y * n.y * a, -n.y);
}

// x in the gnomonic projection around direction a from p (axes u, v): false when x is not in
// front of p.
PN_INLINE bool ml_gnomonic(vec3 p, vec3 a, vec3 u, vec3 v, vec3 x, PN_OUT(float) wx, PN_OUT(float) wy) {
  vec3 dx = x - p;
  float z = dot(dx, a);
  wx = 0.0f;
  wy = 0.0f;
  if (!(z > 1e-6f)) return false;
  wx = dot(dx, u) / z;
  wy = dot(dx, v) / z;
  return true;
}

// Whether some caster box can shadow receiver p (shadowable_receivers): a box meets the cone from
// p to the light, tested conservatively in a gnomonic projection around the direction to the
// light's centre (the boxes' corners' window against the light outline's; a box with a corner not
// in front of p keeps p). outline: n_outline points (x, y, z); boxes: n_boxes boxes (lo x y z,
// hi x y z).
PN_INLINE bool ml_shadowable(vec3 p, vec3 light_center, PN_FLOAT_ARRAY outline, int n_outline, PN_FLOAT_ARRAY boxes,
                             int n_boxes) {
  vec3 a = normalize(light_center - p);
  vec3 u;
  vec3 v;
  ml_coordinate_system(a, u, v);
  float lx0 = uintBitsToFloat(0x7f800000u);
  float lx1 = -lx0;
  float ly0 = lx0;
  float ly1 = -lx0;
  for (int k = 0; k < n_outline; ++k) {
    vec3 q = vec3(PN_AT(outline, 3 * k), PN_AT(outline, 3 * k + 1), PN_AT(outline, 3 * k + 2));
    float x;
    float y;
    if (!ml_gnomonic(p, a, u, v, q, x, y)) return true;
    lx0 = min(lx0, x);
    lx1 = max(lx1, x);
    ly0 = min(ly0, y);
    ly1 = max(ly1, y);
  }
  for (int i = 0; i < n_boxes; ++i) {
    vec3 lo = vec3(PN_AT(boxes, 6 * i), PN_AT(boxes, 6 * i + 1), PN_AT(boxes, 6 * i + 2));
    vec3 hi = vec3(PN_AT(boxes, 6 * i + 3), PN_AT(boxes, 6 * i + 4), PN_AT(boxes, 6 * i + 5));
    float bx0 = uintBitsToFloat(0x7f800000u);
    float bx1 = -bx0;
    float by0 = bx0;
    float by1 = -bx0;
    bool front = true;
    for (int c = 0; c < 8 && front; ++c) {
      vec3 corner = vec3((c & 1) != 0 ? hi.x : lo.x, (c & 2) != 0 ? hi.y : lo.y, (c & 4) != 0 ? hi.z : lo.z);
      float x;
      float y;
      front = ml_gnomonic(p, a, u, v, corner, x, y);
      bx0 = min(bx0, x);
      bx1 = max(bx1, x);
      by0 = min(by0, y);
      by1 = max(by1, y);
    }
    if (!front || (bx0 <= lx1 && lx0 <= bx1 && by0 <= ly1 && ly0 <= by1)) return true;
  }
  return false;
}

// Where the segment from receiver r (at depth zr > z_c along dir from eye) to light point q
// crosses depth z_c (light_centre_view's fit to the crossings).
PN_INLINE vec3 ml_segment_crossing(vec3 r, float zr, vec3 q, vec3 eye, vec3 dir, float z_c) {
  float zq = dot(q - eye, dir);
  float t = (zr - z_c) / (zr - zq);
  return r + (q - r) * t;
}

PN_SHARED_END

#endif  // PENUMBRA_SHADOW_MULTILAYER_MULTILAYER_VIEW_SHARED_H
