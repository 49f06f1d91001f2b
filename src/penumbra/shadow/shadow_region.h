// Where an area light's shadows can fall, seen from its centre (agrawala2000 §4's shadow region,
// penumbra's fit of it): the window at unit depth that holds every caster's shadow volume on what it
// can shadow, and its depth range. `lam` fits its LDI's reference view to it, `coherent-rt` its
// reference images, and the maps fitted to the view samples (shadow-map, pcss, afsm) hold the
// receivers in it beyond their max_fov (shadow_map::shadow_reach). It depends on the scene and the
// light only, never on the camera.
#pragma once

#include "penumbra/core/math.h"

namespace penumbra {

struct Scene;
struct AreaLight;

// The reference view's axes: eye at the light centre, forward along the light normal,
// up along the light's t axis (so right = -s): the same axes LightView::frustum builds.
struct LightAxes {
  Vec3f eye, right, up, forward;
};
LightAxes light_axes(const AreaLight& light);

// Where shadows can fall, seen from the light centre: the window [u0, u1] x [v0, v1] at unit
// depth and the linear depths [near, far] of every caster and receiver in it.
struct ShadowRegion {
  bool empty = true;
  float u0 = 0, u1 = 0, v0 = 0, v1 = 0;
  float near = 0, far = 0;
  // > 0 (the cap, max_tan) where some caster's shadow volume reaches beyond it onto something it
  // can shadow: the region was cut there, even when nothing is left of it (empty).
  float cap_tan = 0;
  // The depth within which some caster that can shadow something may lie beyond the cap seen from
  // some point of the light (its lateral reach plus the light's over max_tan): a caster right
  // beside the light, a lamp's shade. Views from points of the light capped at max_tan cannot hold
  // it there; coherent-rt traces the part of each ray nearer the light than this (0: none).
  float light_field = 0;
};

// The region where some part of `light` can be hidden by scene geometry: for every object O
// that can shadow some object O' (itself if O is not planar; another object whose bounds
// overlap O's shadow volume and, when O is planar and the light lies on one side of its
// plane, reach the other side of it), the window of O's bounds grown by the light's
// half-extent divided by O's nearest depth (eq. 3), clipped to the receivers' windows.
// Windows are capped at |u|, |v| <= max_tan; where that cuts a shadow off, cap_tan says so and the
// display traces the points beyond (lam_shared.h lam_beyond_cap).
ShadowRegion fit_shadow_region(const Scene& scene, const AreaLight& light, float max_tan = 4.0f);

}  // namespace penumbra
