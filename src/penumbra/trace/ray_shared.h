// Shadow-ray set-up in the common subset of C++ and GLSL (core/shader_compat.h): where a
// shadow ray leaves a surface and where it ends, for the CPU ray tracer (trace/ray_tracer.h)
// and the GPU's (gpu/bvh_traverse.glsl), so both devices trace the same segments.
#ifndef PENUMBRA_TRACE_RAY_SHARED_H
#define PENUMBRA_TRACE_RAY_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// The offset off a surface at p. p is a barycentric sum of its triangle's corners, and a
// triangle test (Embree's watertight one, the GPU's bvh_traverse.glsl) works on corners minus the
// ray's origin: both are accurate to a few ulps of the coordinates, so the offset scales with the
// largest coordinate, 2^-20 of it (8 to 16 ulps). A 3e-5 floor covers a point near the origin on
// a large triangle (its corners' ulps, not p's, are the error). At 2 x 10^4 from the origin (a
// georeferenced model) that is 0.019, where 2^-15 (~250 ulps, before) moved every ray 0.6 off its
// surface and lit every contact shadow (render/scene_units_test.cpp).
PN_CONST float kRayOffsetFloor = 3.0e-5f;
PN_CONST float kRayOffsetRelative = 9.5367431640625e-7f;  // 2^-20
// The share of p's largest coordinate: how far rounding can move p (shadow_map_shared.h's bias
// floor takes it too).
PN_INLINE float ray_coordinate_rounding(vec3 p) { return max(abs(p.x), max(abs(p.y), abs(p.z))) * kRayOffsetRelative; }
PN_INLINE float ray_offset_epsilon(vec3 p) { return kRayOffsetFloor + ray_coordinate_rounding(p); }

// The unit normal a ray's origin moves along (ng normalised; zero for a degenerate ng).
PN_INLINE vec3 offset_normal(vec3 ng) {
  float len = length(ng);
  return len > 0.0f ? ng / len : vec3(0.0f);
}

// Whether a ray from a surface point toward `dir` starts on the front of the surface (the side
// its unit normal n_unit = offset_normal(ng) points to): the rule every shadow ray here follows,
// one ray at a time, so a thin two-sided surface sees each light point from the point's own
// side. Methods that decide many light points at once (afsm, ssv-rt) split them by it.
PN_INLINE bool leaves_front(vec3 n_unit, vec3 dir) { return n_unit.x * dir.x + n_unit.y * dir.y + n_unit.z * dir.z >= 0.0f; }

// p moved off its surface (geometric normal ng) to the side `dir` leaves into.
PN_INLINE vec3 offset_ray_origin_shared(vec3 p, vec3 ng, vec3 dir) {
  float eps = ray_offset_epsilon(p);
  vec3 n = offset_normal(ng);  // (zero for a degenerate ng: p stays)
  return p + n * (leaves_front(n, dir) ? eps : -eps);
}

// A shadow segment from surface point p (normal ng) to q: origin, unit direction, and its end
// just short of q (trace/ray_tracer.h shadow_ray_to; tnear 0).
PN_INLINE void shadow_segment(vec3 p, vec3 ng, vec3 q, PN_OUT(vec3) org, PN_OUT(vec3) dir, PN_OUT(float) tfar) {
  org = offset_ray_origin_shared(p, ng, q - p);
  vec3 d = q - org;
  float dist = length(d);
  dir = dist > 0.0f ? d / dist : vec3(0.0f, 1.0f, 0.0f);
  tfar = dist * (1.0f - 1e-5f);
}

// One ray of a fan toward a light's samples (RayTracer::transmittance_fan): from p offset by
// `eps` along the unit normal n_unit to the side of the light point p + d, toward p + d, as an
// unnormalised direction whose segment is t in (0, 1 - 1e-5].
PN_INLINE void fan_segment(vec3 p, vec3 n_unit, float eps, vec3 d, PN_OUT(vec3) org, PN_OUT(vec3) dir) {
  float side = leaves_front(n_unit, d) ? eps : -eps;
  org = vec3(p.x + n_unit.x * side, p.y + n_unit.y * side, p.z + n_unit.z * side);
  dir = vec3(p.x + d.x - org.x, p.y + d.y - org.y, p.z + d.z - org.z);
}
PN_CONST float kFanTfar = 1.0f - 1e-5f;

// Whether a point p at distance z in front of a light's plane (z along the light's normal, from
// its centre) lies on that plane or behind it, as far as p's coordinates tell: within its ray
// offset. Such a point blocks none of the light for a receiver in front (the segment to a point of
// the light lies wholly in front of its plane, and every shadow segment stops short of the light:
// shadow_segment, kFanTfar). A ceiling flush with a panel light, or the light's own fixture, lies
// there; a method that projects its casters onto the light, or maps them from the light's side,
// leaves out the triangles whose every corner is there (afsm's casters, single-sample's occluders;
// multilayer_map.cpp starts its map just past the plane).
PN_INLINE bool on_or_behind_light_plane(float z, vec3 p) { return z <= ray_offset_epsilon(p); }

PN_SHARED_END

#endif  // PENUMBRA_TRACE_RAY_SHARED_H
