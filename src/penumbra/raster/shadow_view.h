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
// Receivers outside the cap are not covered (a lookup there finds nothing: lit). Where every
// receiver lies outside it, there is no rest to keep texels for: the cap is kWidestFov.
#pragma once

#include <span>

#include "penumbra/core/math.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/raster/shadow_view_shared.h"

namespace penumbra {

// The field of view (degrees) a fitted window is capped at when no receiver lies within
// max_fov: everything in front of the eye but the last half degree to its plane.
inline constexpr float kWidestFov = 179.0f;

struct ShadowViewFit {
  // Texels along the longer side of the fitted window; the other side gets as many as
  // keep texels square (at least 1).
  int resolution = 1024;
  // Largest angle between the view axis and a window edge, times two (degrees, < 180).
  float max_fov = 120.0f;
  // Nothing closer to the eye than this (world units) is rasterized or fitted; 0 = 1e-4
  // of the casters' (or receivers') bounding diagonal.
  float min_near = 0;
  // Where casters can shadow something, as x/z, y/z in the view's frame (shadow/shadow_region.h,
  // for a view from the light's centre along its normal): the receivers in it beyond max_fov stay
  // in the window too, up to kWidestFov (a street seen from far down its length, its light high
  // over its middle: the boxes near the camera cast their shadows 73-85 degrees off the light's
  // axis). Empty (x0 > x1, the default): max_fov alone.
  float reach_x0 = 0, reach_x1 = -1, reach_y0 = 0, reach_y1 = -1;
};

// The fitted view from `eye` along `dir` (`up` fixes the roll). `receivers`: the points to
// look up (those at linear depth < min_near are ignored); `casters`: bounds of the
// geometry to rasterize (usually Scene::bounds()). Throws penumbra::Error when no receiver
// lies in front of the eye. The three steps below, in one call.
LightView fit_shadow_view(Vec3f eye, Vec3f dir, Vec3f up, std::span<const Vec3f> receivers,
                          const Bounds3f& casters, const ShadowViewFit& fit);

// The fit in three steps, so the receivers can be reduced where they are (the GPU reduces them
// on the device, shadow/shadow_map_common_gpu.h) and the view built by this one code.
// 1. The view's frame: its axes and min_near (from the casters' bounds; where there are none,
//    from the receivers'). Throws on a resolution or max_fov out of range.
struct ShadowViewFrame {
  Vec3f dir, up;                // as given (LightView::frustum takes them)
  shader::ShadowViewAxes axes;  // eye, min_near, right, up, forward
};
ShadowViewFrame shadow_view_frame(Vec3f eye, Vec3f dir, Vec3f up, const Bounds3f& casters,
                                  std::span<const Vec3f> receivers, const ShadowViewFit& fit);
// 2. The receivers' extents of x/z, y/z and z in that frame (shadow_view_project; the
//    receivers nearer than min_near are ignored). Empty (x0 > x1) when none is left.
struct ShadowViewRange {
  float x0 = kInfinity, x1 = -kInfinity, y0 = kInfinity, y1 = -kInfinity, z0 = kInfinity, z1 = -kInfinity;
  void add(const ShadowViewRange& o);
  void add(float x, float y, float z);
};
ShadowViewRange reduce_receivers(const ShadowViewFrame& frame, std::span<const Vec3f> receivers);
// 3. The view: the window of the range, capped at max_fov, with a little slack, near before
//    every caster, far beyond the farthest receiver, square texels. Throws when the range is
//    empty or lies wholly outside the field of view.
LightView build_shadow_view(const ShadowViewFrame& frame, const ShadowViewRange& range, const Bounds3f& casters,
                            const ShadowViewFit& fit);

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
