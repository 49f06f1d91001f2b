// The part of an area light above a receiver's tangent plane, once for both devices: on a
// closed object the light behind that plane is hidden by the object itself, so the methods that
// cannot see a receiver's own surface in their light-space structures (vsm, evsm, msm: a
// filtered depth; occlusion-textures: slices that skip the receiver's own) multiply their V by
// it. Common subset of C++ and GLSL (core/shader_compat.h); the C++ side builds the record in
// shadow/light_horizon.h.
#ifndef PENUMBRA_SHADOW_LIGHT_HORIZON_SHARED_H
#define PENUMBRA_SHADOW_LIGHT_HORIZON_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// The light as a rectangle, 64 bytes (a GPU record inside the methods' own): bytes 0-11 its
// centre, 12-15 half_s, 16-27 its normal (who is in front of it), 28-31 half_t, 32-43 its axis
// s, 44-47 (0), 48-59 its axis t, 60-63 (0); half_s and half_t the half sides of its rectangle
// along s and t (light_horizon.h light_half_axes: a rect's own, a disk's, a sphere's disk's or an
// ellipse's rectangle of equal area).
struct HorizonLight {
  vec3 center;
  float half_s;
  vec3 n;
  float half_t;
  vec3 s;
  float pad0;
  vec3 t;
  float pad1;
};

// The fraction of the light's rectangle above p's tangent plane (normal ng). The signed height over
// the plane is affine over the rectangle: f(u, v) = f00 + fu u + fv v on the unit square; the
// square clipped to f > 0 (Sutherland-Hodgman against one line), its area by the shoelace formula.
PN_INLINE float light_fraction_above(HorizonLight l, vec3 p, vec3 ng) {
  vec3 corner = l.center - l.s * l.half_s - l.t * l.half_t;
  float f00 = dot(ng, corner - p);
  float fu = dot(ng, l.s) * 2.0f * l.half_s;
  float fv = dot(ng, l.t) * 2.0f * l.half_t;
  vec2 square[4] = {vec2(0.0f, 0.0f), vec2(1.0f, 0.0f), vec2(1.0f, 1.0f), vec2(0.0f, 1.0f)};
  vec2 poly[5];
  int n = 0;
  for (int i = 0; i < 4; ++i) {
    vec2 a = square[i];
    vec2 b = square[(i + 1) % 4];
    PN_PRECISE float fa = f00 + fu * a.x + fv * a.y;
    PN_PRECISE float fb = f00 + fu * b.x + fv * b.y;
    if (fa > 0.0f) poly[n++] = a;
    if ((fa > 0.0f) != (fb > 0.0f)) {
      float s = fa / (fa - fb);
      PN_PRECISE float qx = a.x + (b.x - a.x) * s;
      PN_PRECISE float qy = a.y + (b.y - a.y) * s;
      poly[n++] = vec2(qx, qy);
    }
  }
  float area = 0.0f;
  for (int i = 0; i < n; ++i) {
    PN_PRECISE float cross_z = poly[i].x * poly[(i + 1) % n].y - poly[(i + 1) % n].x * poly[i].y;
    area += cross_z;
  }
  return clamp(0.5f * area, 0.0f, 1.0f);
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::HorizonLight) == 64);
#endif

#endif  // PENUMBRA_SHADOW_LIGHT_HORIZON_SHARED_H
