#include "penumbra/shadow/shadow_map_common.h"

#include <algorithm>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/scene/scene.h"

namespace penumbra::shadow_map {

std::vector<ParamSpec> common_param_specs(int default_resolution) {
  return {
      {"resolution", ParamType::Int, default_resolution,
       "texels along the longer side of each depth map (the view is fitted to the receivers; texels are square)",
       {}, 16, 16384},
      {"max_fov", ParamType::Float, 120.0,
       "largest field of view of a map, degrees: receivers beyond it (grazing the light's plane) that a caster can "
       "shadow widen the map to hold them (shadow-map, pcss) or are traced (multi-view-sm); the others are lit",
       {}, 1, 179},
      {"bias", ParamType::Float, 1e-3, "constant depth bias, world units of linear depth, kept between 64 float epsilons of the receiver's depth and one texel (a scene in any unit)", {}, 0, 1e30},
      {"slope_bias", ParamType::Float, 1.0,
       "slope-scaled bias in texels: adds slope_bias x texel size x the receiver's depth slope (depth change per "
       "texel / texel size; tan(angle between normal and light direction) on the axis) x max(1, lookup distance in "
       "texels); unused with receiver_plane",
       {}, 0, 1e30},
      {"max_slope", ParamType::Float, 10.0, "cap on the depth slope in the slope-scaled bias and on the receiver plane's slope",
       {}, 0, 1e30},
      {"receiver_plane", ParamType::Bool, true,
       "compare each texel with the receiver's tangent plane at that texel (receiver plane depth bias) instead of the "
       "point's depth minus the slope-scaled bias",
       {}},
  };
}

ViewParams view_params(const ParamSet& p) {
  ViewParams v;
  v.resolution = p.get_int("resolution");
  v.max_fov = p.get_float("max_fov");
  return v;
}

BiasParams bias_params(const ParamSet& p) {
  BiasParams b;
  b.bias = p.get_float("bias");
  b.slope_bias = p.get_float("slope_bias");
  b.max_slope = p.get_float("max_slope");
  b.receiver_plane = p.get_bool("receiver_plane");
  return b;
}

void add_map_memory(MemoryTally& tally, int resolution, const MemoryQuery& q) {
  const ViewSize v = fitted_view_bound(resolution);
  tally.add(DepthMap::bytes(v.width, v.height), "resolution");
  // The gathered triangles, the culled copy a view keeps (at most as many: raster/caster_culling.h)
  // and the rasterizer's scratch.
  tally.add(2 * raster_triangles_bytes(q.triangles) + Rasterizer::scratch_bytes(q.triangles, v.width, v.height),
            kTrianglesSetting);
  tally.add(q.view_samples * sizeof(Vec3f), kViewSamplesSetting);
}

std::vector<Vec3f> receiver_points(const ViewSamples& vs, const AreaLight& light) {
  std::vector<Vec3f> out;
  out.reserve(vs.size());
  for (const ViewSample& s : vs.samples)
    if (in_front_of_light(light, s.p)) out.push_back(s.p);
  return out;
}

ShadowRegion shadow_reach(const Scene& scene, const AreaLight& light) {
  return fit_shadow_region(scene, light, std::tan(radians(kWidestFov) * 0.5f));
}

void set_reach(ShadowViewFit& fit, const ShadowRegion& reach) {
  if (reach.empty) return;
  fit.reach_x0 = reach.u0;
  fit.reach_x1 = reach.u1;
  fit.reach_y0 = reach.v0;
  fit.reach_y1 = reach.v1;
}

LightView light_view_from(const AreaLight& light, Vec3f eye, std::span<const Vec3f> receivers,
                          const Bounds3f& casters, int resolution, float max_fov, const ShadowRegion* reach) {
  ShadowViewFit fit;
  fit.resolution = resolution;
  fit.max_fov = max_fov;
  if (reach) set_reach(fit, *reach);
  return fit_shadow_view(eye, light.frame.n, light.frame.t, receivers, casters, fit);
}

shader::ShadowMapView shadow_map_view(const LightView& view, float z_min) {
  shader::ShadowMapView m{};
  m.view = view.shared();
  m.focal = focal_texels(view);
  m.inv_focal = 1.0f / m.focal;
  m.z_min = z_min;
  return m;
}

bool same_fitted_view(const LightView& a, const LightView& b) {
  return a.width() == b.width() && a.height() == b.height() && a.near() == b.near() && a.far() == b.far() &&
         a.window_left() == b.window_left() && a.window_right() == b.window_right() &&
         a.window_bottom() == b.window_bottom() && a.window_top() == b.window_top();
}

void ShadowDepthMap::render(Rasterizer& rasterizer, RasterTriangleView triangles, const LightView& view) {
  if (!view.is_perspective()) throw Error("ShadowDepthMap: the view must be perspective");
  view_ = view;
  rasterizer.depth_map(triangles, view, RasterFilter{}, &map_);
  float zmin = kInfinity;
  for (float z : map_.z) zmin = std::min(zmin, z);
  z_min_ = zmin;
  shared_ = shadow_map_view(view, zmin);
}

size_t ShadowDepthMap::memory_bytes() const {
  return map_.z.size() * sizeof(float) + map_.depth.size() * sizeof(float) + map_.opacity.size() * sizeof(float) +
         map_.triangle.size() * sizeof(uint32_t);
}

void LightCentreMap::prepare(const Scene& scene, const AreaLight& light, MethodStats& stats, bool hold_reach) {
  reach_ = {};
  if (hold_reach) {
    ScopedPhase phase(stats, "reach");
    reach_ = shadow_reach(scene, light);
  }
  ScopedPhase phase(stats, "gather");
  triangles_ = gather_raster_triangles(scene);
  culling_.build(triangles_);
  scene_bounds_ = scene.bounds();
  valid_ = false;
}

bool LightCentreMap::update(const AreaLight& light, const ViewSamples& vs, const ViewParams& params,
                            MethodStats& stats) {
  LightView view;
  uint64_t outside = 0;
  {
    ScopedPhase phase(stats, "fit");
    std::vector<Vec3f> receivers = receiver_points(vs, light);
    if (receivers.empty()) return false;
    view = light_view_from(light, light.center, receivers, scene_bounds_, params.resolution, params.max_fov, &reach_);
    // Receivers beyond max_fov that no caster can shadow (or too close to the light's plane):
    // not covered, lit.
    for (Vec3f p : receivers) {
      Vec3f t = view.to_texel(p);
      outside += !(t.z >= view.near() && t.x >= 0 && t.y >= 0 && t.x < view.width() && t.y < view.height());
    }
  }
  if (!(valid_ && same_fitted_view(map_.view(), view))) {
    ScopedPhase phase(stats, "raster");
    uint64_t culled = 0;
    map_.render(rasterizer_, culling_.visible(triangles_, view, visible_, &culled), view);
    stats.add_count("culled_triangles", culled);
    valid_ = true;
    ++renders_;
  }
  stats.memory_bytes = std::max<uint64_t>(stats.memory_bytes, map_.memory_bytes());
  stats.extra["map_width"] = map_.map().width;
  stats.extra["map_height"] = map_.map().height;
  stats.extra["receivers_outside_map"] = outside;
  return true;
}

}  // namespace penumbra::shadow_map
