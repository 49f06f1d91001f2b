#include "penumbra/shadow/coherent_rt/depth_image_tracer.h"

#include <algorithm>
#include <cmath>

namespace penumbra::coherent_rt {

void TraceCounters::add(const TraceCounters& o) {
  rays += o.rays;
  blocked += o.blocked;
  maps_walked += o.maps_walked;
  clear_misses += o.clear_misses;
  intervals_exhausted += o.intervals_exhausted;
  connected_hits += o.connected_hits;
  hidden_everywhere += o.hidden_everywhere;
  walk.add(o.walk);
}

namespace {

using Span = TraceScratch::Span;

// Appends [a, b] to spans sorted by start, merging with the last one when they touch.
inline void push_span(std::vector<Span>& spans, float a, float b) {
  if (!spans.empty() && a <= spans.back().b + 1e-6f) {
    spans.back().b = std::max(spans.back().b, b);
    return;
  }
  spans.push_back({a, b});
}

struct WalkOutcome {
  bool hit = false;
  bool connected = false;  // hit found at an inner node (no exact point)
  float t = 0;             // segment parameter of the hit
};

// agrawala2000 §5.1 footnote 2: the exact test of one texel. The floor is hit when its
// depth lies in the ray's depth interval over the texel; at the texel's exit edge the wall
// to a connected neighbour is hit when the ray's depth there lies between the two floors.
// kSpans: also collect the parts where the ray passes behind the floor (occlusion spans).
template <bool kSpans>
WalkOutcome walk_map(const ReferenceImage& img, const DepthImageSegment& seg, const DepthWalkOptions& wopt,
                     bool connectedness, std::vector<Span>* behind, DepthWalkCounters* counters) {
  WalkOutcome out;
  const Vec2f dir = seg.p1 - seg.p0;
  const int W = img.width, H = img.height;
  auto leaf = [&](const DepthWalkTexel& tx) {
    const float f = img.floor_at(tx.x, tx.y);
    const float dlo = std::min(tx.d_enter, tx.d_exit), dhi = std::max(tx.d_enter, tx.d_exit);
    if (f >= dlo && f <= dhi) {
      out.hit = true;
      float dd = tx.d_exit - tx.d_enter;
      out.t = dd != 0 ? std::clamp(tx.t_enter + (f - tx.d_enter) / dd * (tx.t_exit - tx.t_enter), tx.t_enter, tx.t_exit)
                      : tx.t_enter;
      return WalkStep::Stop;
    }
    if (tx.t_exit < seg.t1) {
      const Vec2f pe = seg.at(tx.t_exit);
      constexpr float kEdge = 1e-3f;
      int ex = dir.x > 0 && pe.x >= tx.x + 1 - kEdge ? 1 : (dir.x < 0 && pe.x <= tx.x + kEdge ? -1 : 0);
      int ey = dir.y > 0 && pe.y >= tx.y + 1 - kEdge ? 1 : (dir.y < 0 && pe.y <= tx.y + kEdge ? -1 : 0);
      if (ex != 0 || ey != 0) {
        int nx = tx.x + ex, ny = tx.y + ey;
        if (nx >= 0 && ny >= 0 && nx < W && ny < H && ((img.links_at(tx.x, tx.y) >> neighbour_bit(ex, ey)) & 1u)) {
          float g = img.floor_at(nx, ny);
          if (tx.d_exit >= std::min(f, g) && tx.d_exit <= std::max(f, g)) {
            out.hit = true;
            out.t = tx.t_exit;
            return WalkStep::Stop;
          }
        }
      }
    }
    if constexpr (kSpans) {
      // No floor hit: the ray is on one side of the floor over the whole texel.
      if (dlo > f) push_span(*behind, tx.t_clip_enter, tx.t_clip_exit);
    }
    return WalkStep::Continue;
  };
  auto node = [&](const DepthWalkNode& n) {
    // §5.1.1: the ray passes from in front of every surface of a connected node to behind
    // all of them inside it, so it crosses the surface there.
    if (connectedness && n.box_ray.lo <= n.range.lo && n.box_ray.hi >= n.range.hi && img.node_connected(n.level, n.x, n.y)) {
      out.hit = true;
      out.connected = true;
      float dd = seg.d1 - seg.d0, mid = 0.5f * (n.range.lo + n.range.hi);
      out.t = dd != 0 ? std::clamp((mid - seg.d0) / dd, n.t_enter, n.t_exit) : n.t_enter;
      return NodeStep::Stop;
    }
    return NodeStep::Descend;
  };
  if constexpr (kSpans) {
    walk_depth_image_with_skips(
        img.pyramid, seg, wopt, leaf, node,
        [&](const DepthWalkSkip& s) {
          if (s.reason == SkipReason::Behind) push_span(*behind, s.t_enter, s.t_exit);
        },
        counters);
  } else {
    walk_depth_image(img.pyramid, seg, wopt, leaf, node, counters);
  }
  return out;
}

}  // namespace

TraceResult DepthImageTracer::trace(Vec3f p, Vec3f q, bool need_point, TraceScratch& scratch,
                                    TraceCounters* counters) const {
  constexpr int kMaxMaps = 8;
  const int nmaps = std::min<int>(kMaxMaps, static_cast<int>(images_.size()));
  ProjectedSegment ps[kMaxMaps];
  float length[kMaxMaps];
  int order[kMaxMaps];
  int nvalid = 0;
  for (int k = 0; k < nmaps; ++k) {
    const ReferenceImage& img = images_[k];
    if (!project_to_depth_image(img.view, p, q, &ps[k])) continue;
    float ta = 0, tb = 1;
    // A map whose image the ray misses says nothing about it.
    if (!ps[k].segment.clip_to_box(0, 0, float(img.width), float(img.height), &ta, &tb)) continue;
    Vec2f d = ps[k].segment.p1 - ps[k].segment.p0;
    length[k] = (tb - ta) * std::sqrt(dot(d, d));
    order[nvalid++] = k;
  }
  // §5.1.2 (after Chang): shortest clipped epipolar segment first.
  if (options_.ranking)
    for (int i = 1; i < nvalid; ++i)  // insertion sort: a handful of maps, stable, no allocation
      for (int j = i; j > 0 && length[order[j]] < length[order[j - 1]]; --j) std::swap(order[j], order[j - 1]);

  DepthWalkOptions wopt;
  wopt.minmax_clipping = options_.minmax_clipping;
  const bool connectedness = options_.connectedness && !need_point;
  const bool spans = options_.clear_miss || options_.occlusion_intervals;
  TraceCounters c;
  c.rays = 1;
  TraceResult result;
  std::vector<Span>& intervals = scratch.intervals;  // in the world parameter s of p + s (q - p)
  intervals.clear();
  intervals.push_back({0.0f, 1.0f});
  bool whole_ray = true;  // whether `intervals` is still the whole ray
  bool ended = false;  // by a clear miss or when no occlusion interval was left
  for (int i = 0; i < nvalid && !result.blocked; ++i) {
    const ReferenceImage& img = images_[order[i]];
    const ProjectedSegment& pk = ps[order[i]];
    ++c.maps_walked;
    std::vector<Span>& next = scratch.next;
    next.clear();
    for (const Span& iv : intervals) {
      // The part of the interval between near and far; the rest holds no surface.
      float sa = std::max(iv.a, pk.s0), sb = std::min(iv.b, pk.s1);
      if (sa > sb) continue;
      DepthImageSegment seg = pk.segment;
      seg.t0 = std::clamp(pk.segment_param(sa), 0.0f, 1.0f);
      seg.t1 = std::clamp(pk.segment_param(sb), 0.0f, 1.0f);
      if (seg.t0 > seg.t1) std::swap(seg.t0, seg.t1);
      std::vector<Span>& walked = scratch.walked;
      walked.clear();
      WalkOutcome w = spans ? walk_map<true>(img, seg, wopt, connectedness, &walked, &c.walk)
                            : walk_map<false>(img, seg, wopt, connectedness, nullptr, &c.walk);
      if (w.hit) {
        result.blocked = true;
        result.has_point = !w.connected;
        result.point = p + (q - p) * pk.world_param(w.t);
        c.connected_hits += w.connected;
        break;
      }
      // This walk's spans back to the world parameter (monotonic in t).
      for (const Span& sp : walked) {
        float a = pk.world_param(sp.a), b = pk.world_param(sp.b);
        next.push_back({std::min(a, b), std::max(a, b)});
      }
    }
    if (result.blocked) break;
    if (options_.occlusion_intervals) {
      if (next.empty()) {
        ++(whole_ray ? c.clear_misses : c.intervals_exhausted);
        ended = true;
        break;
      }
      std::swap(intervals, next);
      whole_ray = false;
    } else if (options_.clear_miss && next.empty()) {
      ++c.clear_misses;
      ended = true;
      break;
    }
  }
  // Parts of the ray hidden behind surfaces in every map and no intersection found: the
  // paper's answer is "unblocked" (§5.1.2); hidden_blocks answers "blocked" instead.
  if (!result.blocked && !ended && options_.occlusion_intervals && nvalid > 0) {
    ++c.hidden_everywhere;
    if (options_.hidden_blocks) {
      result.blocked = true;
      result.has_point = true;
      result.point = p + (q - p) * (0.5f * (intervals.front().a + intervals.front().b));
    }
  }
  c.blocked = result.blocked;
  if (counters) counters->add(c);
  return result;
}

}  // namespace penumbra::coherent_rt
