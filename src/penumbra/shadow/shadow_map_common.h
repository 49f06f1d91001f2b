// What the shadow-map methods share (`shadow-map`, `pcss`, `multi-view-sm` in baseline/, and
// `vsm`, `evsm`, `msm` in filtered_moments/): their bias parameters, the view from a point on
// the light, the light-centre depth map, and the depth comparison of a view sample against
// one depth map. docs/methods/shadow-map.md states the conventions. The per-sample math is
// shadow_map_shared.h's (the GPU kernels run the same functions); ShadowDepthMap calls it.
//
// A view sample p (geometric normal ng) seen from a map whose eye is e:
// - p is *in front of the light* when dot(p - c, n) > 0 (c, n: the light's centre and
//   normal; for a sphere light, the disk facing the scene). Other points see nothing of the
//   light's emitting side and get V = 0, as with `reference`.
// - p *faces* e when dot(ng, e - p) > 0. Where p lies on a closed object (SceneObject::
//   closed) and does not face e, the segment to e runs through the object's inside and
//   leaves it through its surface: blocked (that is what a shadow ray does; the ray tracer
//   offsets its origin toward the light, here into the object). The depth comparison would
//   be a coin toss there (acne at terminators). On an open surface (a plane, a leaf) the
//   ray tracer's offset puts the origin on the light's side, so its own surface never
//   blocks it; the maps then decide, as for any point.
// - Depth comparison at texel t (nearest-texel lookup, no interpolation): the nearest
//   surface z_t of the map blocks p when z_t < ref(t), where ref(t) is
//     slope bias (default):     z_p - bias - slope_bias * s * min(k, max_slope) * max(1, d_t)
//     receiver plane:           z_plane(t) - bias
//   z_p is p's linear depth, s the world size of one texel at z_p, d_t the distance in
//   texels from p's projection to the centre of t, z_plane(t) the depth of p's tangent
//   plane along the ray through t's centre (clamped to [z_p - max_slope * s * max(1, d_t),
//   z_p]: nothing behind p blocks it), and k the tangent plane's depth slope: its
//   linear-depth change per texel in units of s (tan of the angle between ng and the light
//   direction on the view axis; off the axis larger, since linear depth is measured along
//   the axis, not along the ray).
// - A blocking surface of opacity a lets 1 - a through (only the nearest surface of a texel
//   is known: a map cannot see several semi-transparent layers, which is what xie2007 §5
//   addresses).
#pragma once

#include <cmath>
#include <span>
#include <vector>

#include "penumbra/raster/caster_culling.h"
#include "penumbra/raster/depth_map.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/raster/rasterizer.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/scene/light.h"
#include "penumbra/shadow/params.h"
#include "penumbra/shadow/shadow_map_shared.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/shadow/shadow_region.h"
#include "penumbra/shadow/stats.h"
#include "penumbra/shadow/view_samples.h"

namespace penumbra::shadow_map {

struct BiasParams {
  float bias = 1e-3f;         // constant, world units of linear depth
  float slope_bias = 1.0f;    // texels, scaled by the receiver's depth slope k
  float max_slope = 10.0f;    // cap on k (and on the receiver plane's slope)
  bool receiver_plane = false;  // the parameter tables' default is true (common_param_specs)
  // As the shared functions take them (shadow_map_shared.h).
  shader::ShadowBias shared() const { return {bias, slope_bias, max_slope, receiver_plane ? 1u : 0u}; }
};

// The view parameters every shadow-map baseline has.
struct ViewParams {
  int resolution = 1024;
  float max_fov = 120.0f;
};

// The parameter table entries every shadow-map baseline has: resolution, max_fov, bias,
// slope_bias, max_slope, receiver_plane. receiver_plane is on by default for all of them (issue
// 34: the slope-scaled bias grows with the texel, so on leaves in a wide map it let every leaf
// within about a metre of a receiver through: multi-view-sm on the forest 0.054 -> 0.032, and
// no scene shipped got worse; docs/methods/shadow-map.md).
std::vector<ParamSpec> common_param_specs(int default_resolution);
BiasParams bias_params(const ParamSet& p);
ViewParams view_params(const ParamSet& p);

// What one depth map from the light costs a baseline, added to `tally`: the gathered
// triangles, the map itself (resolution^2 texels, the bound of a fitted window), the
// rasterizer's scratch and the receivers' positions a fit collects (one per view sample).
void add_map_memory(MemoryTally& tally, int resolution, const MemoryQuery& q);

// Whether p is in front of the light's emitting plane (see above).
inline bool in_front_of_light(const AreaLight& light, Vec3f p) {
  return shader::sm_in_front_of_light(light.center, light.frame.n, p);
}

// Positions of the view samples in front of the light (the receivers a map must cover).
std::vector<Vec3f> receiver_points(const ViewSamples& vs, const AreaLight& light);

// Where the light's casters can shadow something, seen from its centre, up to kWidestFov: the
// shadow region (shadow_region.h) cut there instead of at 76 degrees. Per light, camera-free.
ShadowRegion shadow_reach(const Scene& scene, const AreaLight& light);
// `fit` holds the receivers in `reach` beyond its max_fov too (ShadowViewFit::reach; for a view
// from the light's centre, whose frame the region's window is in).
void set_reach(ShadowViewFit& fit, const ShadowRegion& reach);

// The view from `eye` (a point on the light's plane) along the light's normal, its roll
// fixed by the light's t axis, fitted to the receivers with the near plane before every
// caster and a field of view of at most max_fov degrees (raster/shadow_view.h), wider where
// `reach` (for eye = the light's centre) holds receivers beyond it.
LightView light_view_from(const AreaLight& light, Vec3f eye, std::span<const Vec3f> receivers,
                          const Bounds3f& casters, int resolution, float max_fov,
                          const ShadowRegion* reach = nullptr);

// A view sample as one map sees it (texel, depth, texel size, depth slope, receiver plane,
// facing): shadow_map_shared.h's ShadowReceiver.
using Receiver = shader::ShadowReceiver;

// One depth map and its view, with the comparisons of the header comment (shadow_map_shared.h's
// functions over the map's planes).
class ShadowDepthMap {
 public:
  // Renders the nearest surface of `triangles` seen from `view` (semi-transparent casters
  // included; see the header comment). The view must be perspective (fit_shadow_view's).
  void render(Rasterizer& rasterizer, RasterTriangleView triangles, const LightView& view);

  const LightView& view() const { return view_; }
  const DepthMap& map() const { return map_; }
  // The smallest depth in the map (+inf if it is empty): xie2007's z_min.
  float z_min() const { return z_min_; }
  size_t memory_bytes() const;
  // The view as the shared functions take it (with focal length and z_min).
  const shader::ShadowMapView& shared() const { return shared_; }

  Receiver receiver(Vec3f p, Vec3f ng, const BiasParams& b) const {
    return shader::sm_receiver(shared_, p, ng, b.shared());
  }

  // The depth a surface at texel (x, y) must be in front of to block the receiver.
  float reference_depth(const Receiver& r, int x, int y, const BiasParams& b) const {
    return shader::sm_reference_depth(r, x, y, b.shared());
  }

  // The fraction of light texel (x, y) lets through to a receiver whose reference depth
  // there is `ref`: 1 outside the map or when its surface is not in front of ref,
  // otherwise 1 - opacity.
  float transmit(int x, int y, float ref) const {
    return shader::sm_transmit(map_.z.data(), map_.opacity.data(), map_.width, map_.height, x, y, ref);
  }
  // The same at a texel-space point (its texel: floor of the coordinates).
  float transmit_at(const Receiver& r, Vec2f texel, const BiasParams& b) const {
    return shader::sm_transmit_at(map_.z.data(), map_.opacity.data(), shared_, r, texel, b.shared());
  }
  // The hard-shadow lookup of one point at its own texel: 0 when p lies on a closed
  // object and does not face the eye, else transmit_at(receiver(p, ng), its texel). The
  // same numbers as those calls, with the per-map set-up hoisted (what multi-view-sm and
  // shadow-map do per point and map).
  float lookup(Vec3f p, Vec3f ng, bool closed, const BiasParams& b) const {
    return shader::sm_lookup(map_.z.data(), map_.opacity.data(), shared_, p, ng, closed, b.shared());
  }

  // Depth of the nearest surface at a texel-space point (+inf outside the map or empty).
  float depth_at(Vec2f texel) const {
    int x = static_cast<int>(std::floor(texel.x)), y = static_cast<int>(std::floor(texel.y));
    if (x < 0 || y < 0 || x >= map_.width || y >= map_.height) return kInfinity;
    return map_.z[map_.index(x, y)];
  }

 private:
  LightView view_;
  DepthMap map_;
  float z_min_ = kInfinity;
  shader::ShadowMapView shared_{};
};

// The view for the shared functions: `view`'s RasterView, its focal length and `z_min`.
shader::ShadowMapView shadow_map_view(const LightView& view, float z_min);

// Whether two fitted views are the same (resolution, depth range, window): a map rendered for
// one serves the other (LightCentreMap re-renders only when they differ).
bool same_fitted_view(const LightView& a, const LightView& b);

// The scene's triangles and the map from the light's centre (shadow-map, pcss), fitted to
// the receivers of the view samples it is asked about and re-rendered only when their
// bounds or the resolution change (a camera change that keeps the receivers in view
// reuses it).
class LightCentreMap {
 public:
  // Gathers the scene's triangles (phase "gather") and, with hold_reach, the light's shadow reach
  // (phase "reach": the map then holds the receivers beyond max_fov a caster can shadow); call
  // again when the geometry or the light changes.
  void prepare(const Scene& scene, const AreaLight& light, MethodStats& stats, bool hold_reach = true);
  // Makes map() serve `vs` (phase "raster" when it renders). False if no view sample is in
  // front of the light (there is nothing to look up then).
  bool update(const AreaLight& light, const ViewSamples& vs, const ViewParams& view, MethodStats& stats);
  const ShadowDepthMap& map() const { return map_; }
  RasterTriangleView triangles() const { return triangles_; }
  // How many times update() has rendered the map: what a method that derives structures
  // from the map (the filtered moments of shadow/filtered_moments/) compares to know when
  // to rebuild them.
  uint64_t renders() const { return renders_; }

 private:
  RasterTriangles triangles_;
  CasterCulling culling_;              // the casters outside a fitted view are not rasterized
  std::vector<RasterTriangle> visible_;  // those inside, when some are culled
  Bounds3f scene_bounds_;
  ShadowRegion reach_;  // shadow_reach
  Rasterizer rasterizer_;
  ShadowDepthMap map_;
  bool valid_ = false;
  uint64_t renders_ = 0;
};

// Where a light point q lands in a map from the light's centre, per unit of
// (1/z_blocker - 1/z_receiver): the point at depth z_b on the segment from a receiver at
// depth z_r to q projects at texel(receiver) + kernel_offset(q) * (1/z_b - 1/z_r). Exact
// for a light lying in the view's z = 0 plane (rect, disk, a sphere's disk): the shadow of
// a blocker plane at depth z_b is the light's own shape scaled by that factor (the PCSS
// kernel, Fernando 2005; xie2007 eq. 1 for a disk).
inline Vec2f kernel_offset(const LightView& v, float focal, Vec3f q) {
  Vec3f d = q - v.eye();
  return {focal * dot(d, v.right()), -focal * dot(d, v.up())};
}

// xie2007 eq. 1: the radius in texels of the region around a receiver's texel where
// blockers of a light of radius `light_radius` can lie: resolution * light_radius *
// (1/z_min - 1/p.z). `focal` is the focal length in texels (raster/shadow_view.h
// focal_texels; the paper's "resolution" for a view whose window is one unit wide at unit
// distance). Zero when p.z <= z_min (nothing can be in front of p).
inline float xie2007_filter_size(float focal, float light_radius, float z_min, float pz) {
  return shader::sm_xie2007_filter_size(focal, light_radius, z_min, pz);
}

// Fernando 2005 (PCSS): penumbra width at the receiver, w = (d_receiver - d_blocker) *
// light_size / d_blocker, in world units; divided by the receiver's depth and multiplied
// by the focal length it is the filter radius in texels (the same scaling as eq. 1 with
// z_min replaced by the average blocker depth).
inline float pcss_penumbra_width(float light_size, float d_blocker, float d_receiver) {
  if (!(d_blocker > 0) || !(d_receiver > d_blocker)) return 0.0f;
  return (d_receiver - d_blocker) * light_size / d_blocker;
}

}  // namespace penumbra::shadow_map
