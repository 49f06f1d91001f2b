// The near field of a shadow ray, once for both devices and for every method that has one
// (penumbra's addition to coherent-rt, mlsm, mtsm, multi-view-sm, vsm, evsm and msm;
// coherent-rt.md, multilayer.md, multi-view-sm.md and vsm.md, "The near field"): the part of the
// segment from a receiver p toward a light point that is traced through the scene itself, before
// the method's light-space structure (depth images, a multilayer map, one light point's depth map,
// a filtered moment map) answers for the rest. Common subset of C++ and GLSL
// (core/shader_compat.h).
#ifndef PENUMBRA_SHADOW_NEAR_FIELD_SHARED_H
#define PENUMBRA_SHADOW_NEAR_FIELD_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// The light's width as the near field reads it: the side of the square of the light's area
// (AreaLight::area: a rect's own, a disk's, a sphere's cross-section), a penumbra's typical
// width per unit of (occluder-to-receiver / occluder-to-light) distance ratio.
PN_INLINE float near_field_light_width(float light_area) { return sqrt(max(0.0f, light_area)); }

// How far from p the ray is traced. An occluder at distance d from p, on a segment of length
// `segment` to a light of width L, casts a penumbra L d / (segment - d) wide at p (similar
// triangles, parker1998 §2's geometry); `resolved` is the narrowest penumbra, in world units at p,
// the structure resolves (the method's `near_field` texels of its images at p's depth). The
// penumbra is narrower than that while d < resolved segment / (L + resolved): that part of the
// ray is traced, where a structure of texels would answer a shadow finer than its texels (a leaf
// a few centimetres under another; a light small against its distance makes it long). 0 with no
// near field (resolved 0); never more than the segment.
PN_INLINE float near_field_length(float resolved, float segment, float light_width) {
  if (!(resolved > 0.0f) || !(segment > 0.0f)) return 0.0f;
  return min(segment, resolved * segment / (max(0.0f, light_width) + resolved));
}

PN_SHARED_END

#endif  // PENUMBRA_SHADOW_NEAR_FIELD_SHARED_H
