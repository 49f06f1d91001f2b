#include "penumbra/shadow/multilayer/multilayer_trace.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "penumbra/raster/depth_image_walk.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/shadow/multilayer/multilayer_trace_shared.h"

namespace penumbra::multilayer {

TraceParams resolve_trace_params(const TraceParams& params, const LightView& view, float z_min, float z_thresh,
                                 float z_thresh_texels) {
  TraceParams out = params;
  const float zmid = std::isfinite(z_min) ? std::sqrt(std::max(z_min, view.near()) * view.far()) : view.far();
  out.z_thresh = z_thresh > 0 ? z_thresh : z_thresh_texels * view.texel_world_size(zmid);
  return out;
}

shader::MlTraceSetup shared_trace_setup(const TraceSetup& s, float z_min) {
  return {s.z_thresh, s.window_tolerance, s.inv_focal,   s.self_bias,   s.stop_below,
          z_min,      s.open_self_bias,   s.near_field,  s.light_width, s.segments_held_beyond};
}

TraceSetup make_trace_setup(const LightView& view, float z_min, const TraceParams& params) {
  TraceSetup s;
  s.view = &view;
  s.z_thresh = params.z_thresh;
  s.self_bias = params.self_bias;
  s.open_self_bias = params.open_self_bias;
  s.stop_below = params.stop_below;
  s.near_field = params.near_field;
  s.light_width = params.light_width;
  s.inv_focal = 1.0f / focal_texels(view);
  // Window depth is concave in z, so [z - t, z + t] spans the most window depth at the
  // smallest z; the lower side is the wider one.
  const float z = std::isfinite(z_min) ? std::max(z_min, view.near()) : view.near();
  const float lower = std::max(view.near(), z - params.z_thresh);
  s.window_tolerance = (view.window_depth(z) - view.window_depth(lower)) * 1.001f + 1e-7f;
  return s;
}

namespace {

using shader::MlRay;

shader::MlTraceCounters no_counts() { return {0, 0, 0, 0, 0}; }

void add_counts(const shader::MlTraceCounters& c, TraceCounters* counters) {
  counters->rays += c.rays;
  counters->nodes += c.nodes;
  counters->texels += c.texels;
  counters->layers_tested += c.tested;
  counters->layer_hits += c.hits;
}

// Rays of one receiver, walked in packets of kDepthWalkPacket: out[i] = Texel(i's texel
// results) as the single-ray traces give them (the shared set-up and leaf tests,
// multilayer_trace_shared.h): 0 below stop_below, kMlUnresolved where a texel set its `unknown`
// and the ray is not blocked.
template <class Map, class Texel>
void trace_packets(const TraceSetup& s, const Map& map, const RayReceiver& r, std::span<const Vec3f> q, float* out,
                   TraceCounters* counters, Texel&& texel) {
  DepthWalkOptions opt;
  opt.tolerance = s.window_tolerance;
  DepthWalkCounters wc;
  const shader::MlTraceSetup ss = shared_trace_setup(s, map.z_min);
  const shader::RasterView& view = s.view->shared();
  for (size_t first = 0; first < q.size(); first += kDepthWalkPacket) {
    const size_t count = std::min<size_t>(kDepthWalkPacket, q.size() - first);
    MlRay rs[kDepthWalkPacket];
    DepthImageSegment segs[kDepthWalkPacket];
    int ray_of[kDepthWalkPacket];
    bool unknown[kDepthWalkPacket] = {};
    int walked = 0;
    for (size_t k = 0; k < count; ++k) {
      bool blocked = false;
      counters->rays++;
      if (!shader::ml_setup_ray(view, ss, r.p, r.ng, r.closed, q[first + k], rs[walked], blocked)) {
        out[first + k] = blocked ? 0.0f : 1.0f;
        continue;
      }
      out[first + k] = 1.0f;
      segs[walked] = rs[walked].ps.segment;
      ray_of[walked++] = static_cast<int>(first + k);
    }
    walk_depth_image_packet(
        map.pyramid, std::span<const DepthImageSegment>(segs, walked), opt,
        [&](int i, const DepthWalkTexel& t) { return texel(ss, rs[i], t, &out[ray_of[i]], unknown[i]); }, &wc);
    for (int i = 0; i < walked; ++i) {
      float& o = out[ray_of[i]];
      if (o < s.stop_below)
        o = 0.0f;
      else if (unknown[i])
        o = shader::kMlUnresolved;
    }
  }
  counters->nodes += wc.nodes;
  counters->texels += wc.texels;
}

}  // namespace

float trace_opaque(const TraceSetup& s, const OpaqueLayerMap& map, const RayReceiver& r, Vec3f q,
                   TraceCounters* counters) {
  const shader::DepthPyramidLevels levels(map.pyramid);
  shader::MlTraceCounters c = no_counts();
  const float v = shader::ml_trace_opaque(s.view->shared(), shared_trace_setup(s, map.z_min), levels, {&map.layers}, r.p,
                                          r.ng, r.closed, q, c);
  add_counts(c, counters);
  return v;
}

float trace_transparent(const TraceSetup& s, const TransparentMap& map, const RayReceiver& r, Vec3f q,
                        TraceCounters* counters) {
  const shader::DepthPyramidLevels levels(map.pyramid);
  shader::MlTraceCounters c = no_counts();
  const float v = shader::ml_trace_transparent(s.view->shared(), shared_trace_setup(s, map.z_min), levels, {&map.layers},
                                               r.p, r.ng, r.closed, q, c);
  add_counts(c, counters);
  return v;
}

void trace_opaque(const TraceSetup& s, const OpaqueLayerMap& map, const RayReceiver& r, std::span<const Vec3f> q,
                  float* out, TraceCounters* counters) {
  uint32_t tested = 0;
  const shader::RasterView& view = s.view->shared();
  trace_packets(s, map, r, q, out, counters,
                [&](const shader::MlTraceSetup& ss, const MlRay& rs, const DepthWalkTexel& t, float* vis,
                    bool& unknown) {
                  const uint32_t test = shader::ml_opaque_texel_test(view, ss, {&map.layers}, rs, r.p, t.x, t.y,
                                                                     t.d_enter, t.d_exit, t.range.hi, tested);
                  if (test == shader::kMlTexelUnknown) unknown = true;  // unless a later texel blocks it
                  if (test != shader::kMlTexelBlocks) return WalkStep::Continue;
                  *vis = 0.0f;
                  counters->layer_hits++;
                  return WalkStep::Stop;
                });
  counters->layers_tested += tested;
}

void trace_transparent(const TraceSetup& s, const TransparentMap& map, const RayReceiver& r,
                       std::span<const Vec3f> q, float* out, TraceCounters* counters) {
  uint32_t tested = 0, hits = 0;
  const shader::RasterView& view = s.view->shared();
  trace_packets(s, map, r, q, out, counters,
                [&](const shader::MlTraceSetup& ss, const MlRay& rs, const DepthWalkTexel& t, float* vis,
                    bool& unknown) {
                  return shader::ml_transparent_texel(view, ss, {&map.layers}, rs, r.p, t.x, t.y, t.t_enter, t.t_exit,
                                                      t.d_enter, t.d_exit, t.range.hi, *vis, unknown, tested, hits)
                             ? WalkStep::Stop
                             : WalkStep::Continue;
                });
  counters->layers_tested += tested;
  counters->layer_hits += hits;
}

}  // namespace penumbra::multilayer
