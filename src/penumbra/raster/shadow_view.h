// The light views of the shadow-map family (shadow maps, PCF, PCSS, one map per light
// sample, layered attenuation maps): a perspective view from a point on an area light,
// looking along the light's normal, whose window holds the receivers (the points that will
// be looked up), whose near plane is pulled in to keep every caster that could stand
// between the light and a receiver, and whose texels are square.
//
// Why fit to the receivers, not to the whole scene: scenes stand on large ground planes
// (8 x 8 in the shipped scenes) of which the camera sees a small part; a map fitted to the
// scene spends most of its texels where nobody looks. Every caster that can block a
// segment from the eye to a receiver projects inside the receivers' window (it lies on the
// same ray), so nothing is lost as long as the near plane is in front of every caster:
// near = max(min_near, the casters' smallest depth). Linear depth is stored in float
// whatever near is (raster.md), so a near plane close to the eye costs no precision.
//
// Receivers seen at grazing angles from the light (a ground plane running off toward the
// light's own plane) would stretch the window toward a 180-degree field of view and leave
// few texels for the rest; the window is therefore capped at max_fov around the view axis.
// Receivers outside the cap are not covered (a lookup there finds nothing: lit).
#pragma once

#include <span>

#include "penumbra/core/math.h"
#include "penumbra/raster/light_view.h"

namespace penumbra {

struct ShadowViewFit {
  // Texels along the longer side of the fitted window; the other side gets as many as
  // keep texels square (at least 1).
  int resolution = 1024;
  // Largest angle between the view axis and a window edge, times two (degrees, < 180).
  float max_fov = 120.0f;
  // Nothing closer to the eye than this (world units) is rasterized or fitted; 0 = 1e-4
  // of the casters' (or receivers') bounding diagonal.
  float min_near = 0;
};

// The fitted view from `eye` along `dir` (`up` fixes the roll). `receivers`: the points to
// look up (those at linear depth < min_near are ignored); `casters`: bounds of the
// geometry to rasterize (usually Scene::bounds()). Throws penumbra::Error when no receiver
// lies in front of the eye.
LightView fit_shadow_view(Vec3f eye, Vec3f dir, Vec3f up, std::span<const Vec3f> receivers,
                          const Bounds3f& casters, const ShadowViewFit& fit);

// The largest image a view fitted at this resolution can have, for memory estimates before
// the fit: the shorter side depends on the receivers, so resolution x resolution bounds it.
struct ViewSize {
  int width = 0, height = 0;
};
inline ViewSize fitted_view_bound(int resolution) { return {resolution, resolution}; }

// The focal length in texels: a point at view-space (x, y, z) lands at texel
// (cx + f x / z, cy - f y / z). Texels of a fitted view are square, so one number serves
// both axes (for other perspective views, the horizontal one).
inline float focal_texels(const LightView& v) {
  return v.near() * static_cast<float>(v.width()) / (v.window_right() - v.window_left());
}

}  // namespace penumbra
