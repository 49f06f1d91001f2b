#include "penumbra/shadow/multilayer/multilayer_trace.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "penumbra/raster/depth_image_walk.h"
#include "penumbra/raster/shadow_view.h"

namespace penumbra::multilayer {

TraceSetup make_trace_setup(const LightView& view, float z_min, const TraceParams& params) {
  TraceSetup s;
  s.view = &view;
  s.z_thresh = params.z_thresh;
  s.self_bias = params.self_bias;
  s.stop_below = params.stop_below;
  s.inv_focal = 1.0f / focal_texels(view);
  // Window depth is concave in z, so [z - t, z + t] spans the most window depth at the
  // smallest z; the lower side is the wider one.
  const float z = std::isfinite(z_min) ? std::max(z_min, view.near()) : view.near();
  const float lower = std::max(view.near(), z - params.z_thresh);
  s.window_tolerance = (view.window_depth(z) - view.window_depth(lower)) * 1.001f + 1e-7f;
  return s;
}

namespace {

// The common part of both traces: the projected segment and the receiver's own-surface
// plane. The receiver's surface is in the map, right where the ray starts; a layer sample
// X (the surface through a texel centre at depth z) can only block the ray if it lies on the
// light point's side of the receiver's tangent plane by more than self_bias texels:
// dot(n, X - p) > bias with n the normal turned toward q. Along the ray through a texel
// centre X(z) = o + d z, so that is A + B z > bias, a bound on z (penumbra's rule; the
// paper leaves self-shadowing to z_thresh).
struct RaySetup {
  ProjectedSegment ps;
  Vec3f n;        // receiver normal toward the light point
  float bias = 0; // world units
};

// False when the ray cannot be blocked by anything in the map (it lies entirely in front
// of the map's nearest surface, or outside the view's depth range). *blocked is set when the
// receiver's own closed object blocks it.
bool setup_ray(const TraceSetup& s, float z_min, const RayReceiver& r, Vec3f q, RaySetup* out, bool* blocked) {
  *blocked = false;
  const Vec3f d = q - r.p;
  const float side = dot(r.ng, d);
  if (r.closed && !(side > 0)) {
    *blocked = true;  // the light point is behind the closed object's surface
    return false;
  }
  out->n = side >= 0 ? r.ng : -r.ng;
  const LightView& v = *s.view;
  const float zp = v.linear_depth(r.p);
  if (!(zp > z_min)) return false;  // nothing in front of the receiver (xie2007 §4.3: clip at z_min)
  if (!project_to_depth_image(v, r.p, q, &out->ps)) return false;
  out->bias = s.self_bias * zp * s.inv_focal;
  return true;
}

// The depths z at texel (x, y) that lie beyond the receiver's own-surface band: z > *lo_bound
// (or z < *hi_bound), as an interval clip of [a, b].
inline bool clip_to_light_side(const TraceSetup& s, const RaySetup& rs, Vec3f p, int x, int y, float* a, float* b) {
  const LightView::TexelRay tr = s.view->texel_ray({x + 0.5f, y + 0.5f});
  const float A = dot(rs.n, tr.origin - p), B = dot(rs.n, tr.dir);
  const float c = rs.bias - A;  // need B z > c
  if (B > 0) *a = std::max(*a, c / B);
  else if (B < 0) *b = std::min(*b, c / B);
  else if (!(0 > c)) return false;
  return *a <= *b;
}

// The leaf test of trace_opaque (xie2007 §4.3, §6.1) at one texel: whether a layer blocks
// the ray there.
bool opaque_texel_blocks(const TraceSetup& s, const OpaqueLayerMap& map, const RaySetup& rs, Vec3f p,
                         const DepthWalkTexel& t, uint64_t* tested) {
  const LightView& v = *s.view;
  const float zt = s.z_thresh;
  const float zlo = v.linear_depth_from_window(std::min(t.d_enter, t.d_exit));
  const float zhi = v.linear_depth_from_window(std::max(t.d_enter, t.d_exit));
  float a = zlo - zt, b = zhi + zt;
  bool clipped = false;
  for (const DepthSample& l : map.layers.layers(t.x, t.y)) {
    ++*tested;
    if (l.z < a || l.z > b) continue;
    if (!clipped) {  // the own-surface bound, once per texel and only when needed
      clipped = true;
      if (!clip_to_light_side(s, rs, p, t.x, t.y, &a, &b)) return false;
      if (l.z < a || l.z > b) continue;
    }
    return true;
  }
  return false;
}

// The largest float below x in magnitude (std::nextafter(x, 0) for a finite non-zero x),
// without the library call.
inline float next_toward_zero(float x) {
  if (x == 0 || x != x) return x;
  return std::bit_cast<float>(std::bit_cast<uint32_t>(x) - 1u);
}

// The leaf test of trace_transparent (xie2007 §5.2) at one texel: multiplies *vis by what
// the ray crosses there; Stop once it falls below stop_below.
WalkStep transparent_texel(const TraceSetup& s, const TransparentMap& map, const RaySetup& rs, Vec3f p,
                           const DepthWalkTexel& t, float* vis, uint64_t* tested, uint64_t* hits) {
  const LightView& v = *s.view;
  const float zt = s.z_thresh;
  const float zlo = v.linear_depth_from_window(std::min(t.d_enter, t.d_exit));
  const float zhi = v.linear_depth_from_window(std::max(t.d_enter, t.d_exit));
  // Opaque layers: the MLSM rule, widened by z_thresh (so mtsm is mlsm on opaque
  // scenes). Semi-transparent samples: counted where the ray's own depth interval over
  // the texel holds them, half-open, with no widening. Consecutive texels' intervals
  // then partition the ray's depths, so each surface the ray passes is counted once;
  // widened windows overlap by 2 z_thresh per texel and would attenuate an oblique ray
  // crossing many texels several times over (penumbra's reading of §5.2's "reduce
  // ray.vis by dv_i" for rays that cross many texels).
  float a = zlo - zt, b = zhi + zt;                  // opaque window
  float ta = zlo, tb = next_toward_zero(zhi);         // transparent window
  if (!(tb >= ta)) tb = ta;
  // The walker's texels are closed boxes: a segment running along a texel edge reaches
  // the texels on both sides with the same interval. Texel (x, y) owns [x, x+1) x
  // [y, y+1): the crossing counts transparent samples only where its midpoint is owned.
  const Vec2f mid = rs.ps.segment.at(0.5f * (t.t_enter + t.t_exit));
  if (static_cast<int>(std::floor(mid.x)) != t.x || static_cast<int>(std::floor(mid.y)) != t.y) {
    ta = kInfinity;
    tb = -kInfinity;
  }
  bool clipped = false;
  for (const TransparentLayer& l : map.layers.at(t.x, t.y)) {
    ++*tested;
    const bool opaque = l.transmit <= 0;
    if (opaque ? (l.z < a || l.z_first > b) : (l.z < ta || l.z_first > tb)) continue;
    if (!clipped) {  // the own-surface bound, once per texel and only when needed
      clipped = true;
      float ca = -kInfinity, cb = kInfinity;
      if (!clip_to_light_side(s, rs, p, t.x, t.y, &ca, &cb)) return WalkStep::Continue;
      a = std::max(a, ca), b = std::min(b, cb);
      ta = std::max(ta, ca), tb = std::min(tb, cb);
    }
    const uint32_t n = opaque ? samples_in(l, a, b) : samples_in(l, ta, tb);
    if (n == 0) continue;
    *hits += opaque ? 1 : n;
    *vis = opaque ? 0.0f : *vis * (n == 1 ? l.transmit : std::pow(l.transmit, static_cast<float>(n)));
    if (*vis < s.stop_below) return WalkStep::Stop;
  }
  return WalkStep::Continue;
}

// Rays of one receiver, walked in packets of kDepthWalkPacket: out[i] = Texel(i's texel
// results) as the single-ray traces give them.
template <class Map, class Texel>
void trace_packets(const TraceSetup& s, const Map& map, const RayReceiver& r, std::span<const Vec3f> q, float* out,
                   TraceCounters* counters, Texel&& texel) {
  DepthWalkOptions opt;
  opt.tolerance = s.window_tolerance;
  DepthWalkCounters wc;
  for (size_t first = 0; first < q.size(); first += kDepthWalkPacket) {
    const size_t count = std::min<size_t>(kDepthWalkPacket, q.size() - first);
    RaySetup rs[kDepthWalkPacket];
    DepthImageSegment segs[kDepthWalkPacket];
    int ray_of[kDepthWalkPacket];
    int walked = 0;
    for (size_t k = 0; k < count; ++k) {
      bool blocked = false;
      counters->rays++;
      if (!setup_ray(s, map.z_min, r, q[first + k], &rs[walked], &blocked)) {
        out[first + k] = blocked ? 0.0f : 1.0f;
        continue;
      }
      out[first + k] = 1.0f;
      segs[walked] = rs[walked].ps.segment;
      ray_of[walked++] = static_cast<int>(first + k);
    }
    walk_depth_image_packet(
        map.pyramid, std::span<const DepthImageSegment>(segs, walked), opt,
        [&](int i, const DepthWalkTexel& t) { return texel(rs[i], t, &out[ray_of[i]]); }, &wc);
  }
  counters->nodes += wc.nodes;
  counters->texels += wc.texels;
}

}  // namespace

float trace_opaque(const TraceSetup& s, const OpaqueLayerMap& map, const RayReceiver& r, Vec3f q,
                   TraceCounters* counters) {
  RaySetup rs;
  bool blocked = false;
  counters->rays++;
  if (!setup_ray(s, map.z_min, r, q, &rs, &blocked)) return blocked ? 0.0f : 1.0f;
  DepthWalkOptions opt;
  opt.tolerance = s.window_tolerance;
  DepthWalkCounters wc;
  uint64_t tested = 0;
  const bool hit = walk_depth_image(
      map.pyramid, rs.ps.segment, opt,
      [&](const DepthWalkTexel& t) {
        return opaque_texel_blocks(s, map, rs, r.p, t, &tested) ? WalkStep::Stop : WalkStep::Continue;
      },
      DescendEveryNode{}, &wc);
  counters->nodes += wc.nodes;
  counters->texels += wc.texels;
  counters->layers_tested += tested;
  if (hit) counters->layer_hits++;
  return hit ? 0.0f : 1.0f;
}

float trace_transparent(const TraceSetup& s, const TransparentMap& map, const RayReceiver& r, Vec3f q,
                        TraceCounters* counters) {
  RaySetup rs;
  bool blocked = false;
  counters->rays++;
  if (!setup_ray(s, map.z_min, r, q, &rs, &blocked)) return blocked ? 0.0f : 1.0f;
  DepthWalkOptions opt;
  opt.tolerance = s.window_tolerance;
  DepthWalkCounters wc;
  uint64_t tested = 0, hits = 0;
  float vis = 1.0f;
  walk_depth_image(
      map.pyramid, rs.ps.segment, opt,
      [&](const DepthWalkTexel& t) { return transparent_texel(s, map, rs, r.p, t, &vis, &tested, &hits); },
      DescendEveryNode{}, &wc);
  counters->nodes += wc.nodes;
  counters->texels += wc.texels;
  counters->layers_tested += tested;
  counters->layer_hits += hits;
  return vis < s.stop_below ? 0.0f : vis;
}

void trace_opaque(const TraceSetup& s, const OpaqueLayerMap& map, const RayReceiver& r, std::span<const Vec3f> q,
                  float* out, TraceCounters* counters) {
  uint64_t tested = 0;
  trace_packets(s, map, r, q, out, counters, [&](const RaySetup& rs, const DepthWalkTexel& t, float* vis) {
    if (!opaque_texel_blocks(s, map, rs, r.p, t, &tested)) return WalkStep::Continue;
    *vis = 0.0f;
    counters->layer_hits++;
    return WalkStep::Stop;
  });
  counters->layers_tested += tested;
}

void trace_transparent(const TraceSetup& s, const TransparentMap& map, const RayReceiver& r,
                       std::span<const Vec3f> q, float* out, TraceCounters* counters) {
  uint64_t tested = 0, hits = 0;
  trace_packets(s, map, r, q, out, counters, [&](const RaySetup& rs, const DepthWalkTexel& t, float* vis) {
    return transparent_texel(s, map, rs, r.p, t, vis, &tested, &hits);
  });
  for (size_t i = 0; i < q.size(); ++i)
    if (out[i] < s.stop_below) out[i] = 0.0f;
  counters->layers_tested += tested;
  counters->layer_hits += hits;
}

}  // namespace penumbra::multilayer
