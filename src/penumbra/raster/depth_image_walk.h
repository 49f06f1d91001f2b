// Hierarchical walk of a 2D segment through a depth image's min/max quadtree
// (MinMaxPyramid): the traversal shared by ray tracing of depth images, agrawala2000 §5.1
// (procedure Trace, after Marcato / Chang) and xie2007 §4.3 (MLSM / MTSM epipolar walks).
//
// A ray (a shadow ray, or any 3D segment) projects into a light view as a texel-space segment
// p(t) = p0 + t (p1 - p0), t in [t0, t1]. Window depth is affine along it (docs/raster.md,
// conventions), so the ray's depth is d(t) = d0 + t (d1 - d0) and its depth interval over any
// sub-segment is the interval of its two ends. The walk descends the pyramid coarse to fine:
// at each node it clips the segment to the node's texel box, optionally (min/max clipping,
// agrawala2000 §5.1.1) to the part where the ray's depth lies inside the node's [min, max]
// widened by a tolerance, skips the node when that part is empty (the overlap test of Trace,
// lines 4-6), and otherwise visits its children in the order the segment enters them. Each
// texel reached goes to a caller-supplied leaf visitor with the segment's parameter and
// depth interval inside the texel (the whole crossing of the texel, not the clipped part):
// the "exact intersection test" (floors and walls, layer scans, ...) is the caller's.
//
// The visitors are template parameters (inlined; nothing allocated, no std::function):
//   leaf(const DepthWalkTexel&) -> WalkStep   (Continue or Stop)
//   node(const DepthWalkNode&)  -> NodeStep   (Descend, Skip or Stop) - optional; called at
//       every inner node that passes the overlap test, before its children, so a caller can
//       decide at a coarse level (agrawala2000 §5.1.1, hierarchical connectedness: "blocked"
//       without descending to the leaves) or prune with its own data.
// Visits are strictly front to back along t (t increasing): for texels, the order of their
// entry parameter. Boxes are closed: a segment along a texel edge or through a corner
// reaches the texels on both sides.
//
// walk_depth_image_packet (at the end) walks up to kDepthWalkPacket rays together (the shadow
// rays of one receiver, which share the nodes down to it), with a SIMD node step: each ray
// gets exactly the single-ray walk's texels, in an order that is not front to back.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <type_traits>
#include <utility>

#include "penumbra/core/math.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/raster/minmax_pyramid.h"

namespace penumbra {

// A segment in a depth image's texel space with an affine depth along it.
struct DepthImageSegment {
  Vec2f p0, p1;          // texel-space points at t = 0 and t = 1
  float d0 = 0, d1 = 0;  // the ray's depth at t = 0 and t = 1 (same kind as the pyramid's)
  float t0 = 0, t1 = 1;  // the part to walk

  Vec2f at(float t) const { return p0 + (p1 - p0) * t; }
  float depth_at(float t) const { return d0 + (d1 - d0) * t; }
  // The ray's depth interval over [ta, tb] (ta <= tb).
  DepthRange depth_over(float ta, float tb) const {
    float a = depth_at(ta), b = depth_at(tb);
    return a <= b ? DepthRange{a, b} : DepthRange{b, a};
  }
  // Clips [*ta, *tb] to the closed box [x0, x1] x [y0, y1]; false when nothing is left.
  bool clip_to_box(float x0, float y0, float x1, float y1, float* ta, float* tb) const {
    return clip_axis(p0.x, p1.x - p0.x, x0, x1, ta, tb) && clip_axis(p0.y, p1.y - p0.y, y0, y1, ta, tb);
  }
  // Clips [*ta, *tb] to where the depth lies in [lo, hi]; false when nothing is left.
  bool clip_to_depth(float lo, float hi, float* ta, float* tb) const {
    return clip_axis(d0, d1 - d0, lo, hi, ta, tb);
  }

 private:
  static bool clip_axis(float p, float d, float lo, float hi, float* ta, float* tb) {
    if (d == 0) return p >= lo && p <= hi && *ta <= *tb;
    float inv = 1.0f / d;
    float a = (lo - p) * inv, b = (hi - p) * inv;
    if (a > b) std::swap(a, b);
    *ta = std::max(*ta, a);
    *tb = std::min(*tb, b);
    return *ta <= *tb;
  }
};

// A world-space segment projected into a light view (project_to_depth_image): the
// texel-space segment with window depth, and the maps back to the world segment.
struct ProjectedSegment {
  DepthImageSegment segment;  // t in [0, 1]: the part in front of near and before far
  float s0 = 0, s1 = 1;       // world-segment parameters of t = 0 and t = 1
  float w0 = 1, w1 = 1;       // homogeneous w at t = 0, 1 (the linear depth; 1 for orthographic)
  float z0 = 0, z1 = 0;       // linear depth at t = 0, 1

  // How far along the world segment (0 at t = 0, 1 at t = 1) the point at t lies
  // (perspective-correct; = t for an orthographic view).
  float world_fraction(float t) const {
    float den = (1 - t) * w1 + t * w0;
    return den != 0 ? t * w0 / den : t;
  }
  // The world-segment parameter s (a + s (b - a)) of the point at t.
  float world_param(float t) const { return s0 + (s1 - s0) * world_fraction(t); }
  // The t of world-segment parameter s (the inverse of world_param).
  float segment_param(float s) const {
    float u = s1 != s0 ? (s - s0) / (s1 - s0) : 0.0f;
    float den = (1 - u) * w0 + u * w1;
    return den != 0 ? u * w1 / den : u;
  }
  // Linear depth of the point at t.
  float linear_depth_at(float t) const { return z0 + (z1 - z0) * world_fraction(t); }
};

// Projects the world segment a + s (b - a), s in [0, 1], into `view`: clips it to
// near <= z <= far (homogeneously: nothing behind the eye is mirrored) and returns the
// texel-space segment with window depth (affine in texel space for both projections). Not
// clipped to the image: the walk does that. False when no part lies between near and far.
bool project_to_depth_image(const LightView& view, Vec3f a, Vec3f b, ProjectedSegment* out);

// One texel reached by the walk.
struct DepthWalkTexel {
  int x = 0, y = 0;
  float t_enter = 0, t_exit = 0;  // the segment's crossing of the (closed) texel, inside [t0, t1]
  float d_enter = 0, d_exit = 0;  // the ray's depth at t_enter and t_exit
  DepthRange range;               // the texel's range in the pyramid
  // The part of the crossing the ancestors' min/max clipping left (= [t_enter, t_exit]
  // without clipping): with walk_depth_image_with_skips, these parts and the skipped spans
  // tile [t0, t1] in order.
  float t_clip_enter = 0, t_clip_exit = 0;
};

// An inner node about to be descended.
struct DepthWalkNode {
  int level = 0, x = 0, y = 0;
  float t_enter = 0, t_exit = 0;  // after box (and, when on, min/max) clipping
  DepthRange ray;                 // the ray's depth over [t_enter, t_exit]
  // The ray's depth over its whole crossing of the node's box (as far as the ancestors'
  // clipping left it): when it contains `range`, the ray passes from in front of everything
  // in the node to behind it (agrawala2000 §5.1.1, hierarchical connectedness).
  DepthRange box_ray;
  DepthRange range;               // the node's range in the pyramid
};

enum class WalkStep { Continue, Stop };
enum class NodeStep { Descend, Skip, Stop };

struct DepthWalkOptions {
  // Node ranges are widened by this much on both sides in the overlap test and in min/max
  // clipping (a depth bias, or room for float rounding), in the pyramid's depth units.
  float tolerance = 0;
  // agrawala2000 §5.1.1, min/max clipping: clip the segment to the node's depth range at
  // every level (off: clipped to node boxes only, so a node's overlap test sees the ray's
  // depth over its whole box crossing).
  bool minmax_clipping = true;
};

struct DepthWalkCounters {
  uint64_t nodes = 0;   // nodes popped (inner nodes and texels), overlap-tested
  uint64_t texels = 0;  // leaf visitor calls
  void add(const DepthWalkCounters& o) {
    nodes += o.nodes;
    texels += o.texels;
  }
};

// Why a span of the segment was not walked down to texels (walk_depth_image_with_skips).
enum class SkipReason {
  InFront,  // the ray is nearer the eye than every surface of the node (minus the tolerance)
  Behind,   // the ray is farther than every surface of the node (plus the tolerance)
  Empty,    // the node holds no surface
  Outside,  // the segment is outside the image
  Pruned,   // the node visitor answered Skip
};

struct DepthWalkSkip {
  float t_enter = 0, t_exit = 0;
  SkipReason reason = SkipReason::Empty;
  int level = 0;  // of the node skipped (-1: outside the image)
};

// The default skip visitor: ignore (compiled away).
struct IgnoreSkips {
  void operator()(const DepthWalkSkip&) const {}
};

// The default node visitor: always descend.
struct DescendEveryNode {
  NodeStep operator()(const DepthWalkNode&) const { return NodeStep::Descend; }
};

namespace depth_walk_detail {

// Clips [*a, *b] to where p + t d lies in [lo, hi] (inv = 1 / d, or anything when d = 0);
// false when nothing is left.
inline bool clip_axis(float p, float d, float inv, float lo, float hi, float* a, float* b) {
  if (d == 0) return p >= lo && p <= hi && *a <= *b;
  float u = (lo - p) * inv, v = (hi - p) * inv;
  if (u > v) std::swap(u, v);
  *a = std::max(*a, u);
  *b = std::min(*b, v);
  return *a <= *b;
}

// The two halves of a node's interval [a, b] on one axis, cut at the midline m between its
// children (index 0: the lower half, 1: the upper): the one part of clip_axis against each
// child's range that the node's own clip has not already applied (the child shares the
// node's other edge, and max/min with an edge [a, b] already respects changes nothing), so
// the result is the same floats as clipping to the child's whole box. in[] is cleared for
// a half the segment misses when it runs parallel to the axis.
inline void split_axis(float p, float d, float inv, float m, float a, float b, float lo_half[2], float hi_half[2],
                       bool in[2]) {
  if (d == 0) {
    in[0] = in[0] && p <= m;
    in[1] = in[1] && p >= m;
    return;
  }
  const float t = (m - p) * inv;
  if (d > 0) {
    hi_half[0] = std::min(b, t);
    lo_half[1] = std::max(a, t);
  } else {
    lo_half[0] = std::max(a, t);
    hi_half[1] = std::min(b, t);
  }
}

}  // namespace depth_walk_detail

// Walks `seg` (from t0 to t1) through `pyramid`, front to back, and reports, besides the
// texels, every span of [t0, t1] it did not descend into, with the reason
// (skip(const DepthWalkSkip&), in order with the texels' clipped parts): what a caller needs
// to know where the ray passed behind or in front of the image's surfaces (agrawala2000
// §5.1.2, occlusion intervals and clear miss). Returns true when a visitor stopped the walk.
template <class LeafVisitor, class NodeVisitor, class SkipVisitor>
bool walk_depth_image_with_skips(const MinMaxPyramid& pyramid, const DepthImageSegment& seg,
                                 const DepthWalkOptions& opt, LeafVisitor&& leaf, NodeVisitor&& node,
                                 SkipVisitor&& skip, DepthWalkCounters* counters = nullptr) {
  constexpr bool kSkips = !std::is_same_v<std::decay_t<SkipVisitor>, IgnoreSkips>;
  struct Entry {
    int level, x, y;  // level -1: a deferred skip span (reason in x)
    float ta, tb;
    DepthRange range;  // the node's, read when it is pushed (its siblings' loads overlap)
  };
  // Depth-first with at most 3 siblings and one deferred span pending per level: 4 * 32 + 2
  // entries cover any image the rasterizer can make (16384^2: 15 levels).
  Entry stack[160];
  int top = 0;
  const int W = pyramid.width(0), H = pyramid.height(0);
  const float tol = opt.tolerance;
  uint64_t n_nodes = 0, n_texels = 0;
  bool stopped = false;
  auto report = [&](float a, float b, SkipReason why, int level) {
    if constexpr (kSkips) {
      if (a <= b) skip(DepthWalkSkip{a, b, why, level});
    }
  };
  // Clipping with the segment's reciprocal slopes computed once (the walk's inner loop
  // clips up to four children per node).
  const float dx = seg.p1.x - seg.p0.x, dy = seg.p1.y - seg.p0.y, dd = seg.d1 - seg.d0;
  const float ix = dx != 0 ? 1.0f / dx : 0.0f, iy = dy != 0 ? 1.0f / dy : 0.0f, id = dd != 0 ? 1.0f / dd : 0.0f;
  using depth_walk_detail::clip_axis;
  using depth_walk_detail::split_axis;
  auto clip_box = [&](float x0, float y0, float x1, float y1, float* a, float* b) {
    return clip_axis(seg.p0.x, dx, ix, x0, x1, a, b) && clip_axis(seg.p0.y, dy, iy, y0, y1, a, b);
  };
  auto clip_depth = [&](float lo, float hi, float* a, float* b) { return clip_axis(seg.d0, dd, id, lo, hi, a, b); };
  // The levels' nodes and sizes, read once per walk.
  const int n_levels = pyramid.levels();
  constexpr int kMaxLevels = 32;
  const DepthRange* level_nodes[kMaxLevels];
  int level_width[kMaxLevels], level_height[kMaxLevels];
  for (int l = 0; l < n_levels && l < kMaxLevels; ++l) {
    level_nodes[l] = pyramid.level(l).data();
    level_width[l] = pyramid.width(l);
    level_height[l] = pyramid.height(l);
  }
  // Which side of [lo, hi] the ray is on at t (outside the widened range).
  auto side = [&](float t, const DepthRange& r) {
    return seg.depth_at(t) < 0.5f * (r.lo + r.hi) ? SkipReason::InFront : SkipReason::Behind;
  };

  float ta = seg.t0, tb = seg.t1;
  if (clip_box(0, 0, float(W), float(H), &ta, &tb)) {
    if constexpr (kSkips) {
      if (ta > seg.t0) report(seg.t0, ta, SkipReason::Outside, -1);
      if (tb < seg.t1) stack[top++] = {-1, int(SkipReason::Outside), 0, tb, seg.t1, {}};
    }
    stack[top++] = {n_levels - 1, 0, 0, ta, tb, level_nodes[n_levels - 1][0]};
  } else {
    report(seg.t0, seg.t1, SkipReason::Outside, -1);
  }

  while (top > 0) {
    Entry e = stack[--top];
    if constexpr (kSkips) {
      if (e.level < 0) {
        report(e.ta, e.tb, SkipReason(e.x), e.y);
        continue;
      }
    }
    ++n_nodes;
    if (e.level == 0) {
      const DepthRange r = e.range;
      if (r.empty()) {
        report(e.ta, e.tb, SkipReason::Empty, 0);
        continue;
      }
      // The whole crossing of the texel (ancestors' clipping only removed parts where the
      // ray is outside their ranges, hence outside this texel's).
      float la = seg.t0, lb = seg.t1;
      if (!clip_box(float(e.x), float(e.y), float(e.x + 1), float(e.y + 1), &la, &lb)) {
        la = e.ta;  // rounding: keep what the parent passed down
        lb = e.tb;
      }
      DepthWalkTexel t;
      t.x = e.x;
      t.y = e.y;
      t.t_enter = la;
      t.t_exit = lb;
      t.d_enter = seg.depth_at(la);
      t.d_exit = seg.depth_at(lb);
      t.range = r;
      t.t_clip_enter = e.ta;
      t.t_clip_exit = e.tb;
      float dlo = std::min(t.d_enter, t.d_exit), dhi = std::max(t.d_enter, t.d_exit);
      if (!(r.lo - tol <= dhi && dlo <= r.hi + tol)) {
        report(e.ta, e.tb, side(0.5f * (e.ta + e.tb), r), 0);
        continue;
      }
      ++n_texels;
      if (leaf(static_cast<const DepthWalkTexel&>(t)) == WalkStep::Stop) {
        stopped = true;
        break;
      }
      continue;
    }
    const DepthRange r = e.range;
    if (r.empty()) {
      report(e.ta, e.tb, SkipReason::Empty, e.level);
      continue;
    }
    float a = e.ta, b = e.tb;
    DepthRange box_ray = seg.depth_over(a, b), ray = box_ray;
    if (opt.minmax_clipping) {
      // What is left lies inside the widened range by construction; testing the depths
      // again would reject single-point overlaps through rounding.
      if (!clip_depth(r.lo - tol, r.hi + tol, &a, &b)) {
        report(e.ta, e.tb, side(0.5f * (e.ta + e.tb), r), e.level);
        continue;
      }
      ray = seg.depth_over(a, b);
      ray.lo = std::max(ray.lo, r.lo - tol);
      ray.hi = std::min(ray.hi, r.hi + tol);
    } else if (!(r.lo - tol <= ray.hi && ray.lo <= r.hi + tol)) {
      report(e.ta, e.tb, side(0.5f * (e.ta + e.tb), r), e.level);
      continue;
    }
    DepthWalkNode n;
    n.level = e.level;
    n.x = e.x;
    n.y = e.y;
    n.t_enter = a;
    n.t_exit = b;
    n.ray = ray;
    n.box_ray = box_ray;
    n.range = r;
    NodeStep step = node(static_cast<const DepthWalkNode&>(n));
    if (step == NodeStep::Skip) {
      report(e.ta, e.tb, SkipReason::Pruned, e.level);
      continue;
    }
    if (step == NodeStep::Stop) {
      stopped = true;
      break;
    }
    if constexpr (kSkips) {
      // The clipped-off ends: before the children now, after them later.
      if (a > e.ta) report(e.ta, a, side(e.ta, r), e.level);
      if (b < e.tb) stack[top++] = {-1, int(side(e.tb, r)), e.level, b, e.tb, {}};
    }
    // Children in the order the segment enters them. The node's interval [a, b] is already
    // clipped to its own box (and every child shares two of its edges), so a child's
    // interval only needs the cut at the node's two midlines: the same floats a clip of the
    // child's whole box gives (max/min with an edge the node's interval already respects
    // change nothing), for a quarter of the work.
    const int cl = e.level - 1, cx0 = 2 * e.x, cy0 = 2 * e.y;
    const bool has_x1 = cx0 + 1 < level_width[cl], has_y1 = cy0 + 1 < level_height[cl];
    const DepthRange* child_nodes = level_nodes[cl];
    const size_t child_width = static_cast<size_t>(level_width[cl]);
    float xa[2] = {a, a}, xb[2] = {b, b}, ya[2] = {a, a}, yb[2] = {b, b};
    bool xin[2] = {true, has_x1}, yin[2] = {true, has_y1};
    if (has_x1) split_axis(seg.p0.x, dx, ix, float((cx0 + 1) << cl), a, b, xa, xb, xin);
    if (has_y1) split_axis(seg.p0.y, dy, iy, float((cy0 + 1) << cl), a, b, ya, yb, yin);
    // Sorted straight into the stack, last to enter first: the stack top is the first child
    // entered (by (ta, tb); among equal ones, the first in y-then-x order).
    Entry* kids = stack + top;
    int nk = 0;
    for (int j = 0; j < 2; ++j) {
      if (!yin[j]) continue;
      for (int i = 0; i < 2; ++i) {
        if (!xin[i]) continue;
        const float ka = std::max(xa[i], ya[j]), kb = std::min(xb[i], yb[j]);
        if (!(ka <= kb)) continue;
        const Entry k{cl, cx0 + i, cy0 + j, ka, kb, child_nodes[static_cast<size_t>(cy0 + j) * child_width + cx0 + i]};
        int n = nk++;
        while (n > 0 && (kids[n - 1].ta < ka || (kids[n - 1].ta == ka && kids[n - 1].tb <= kb))) {
          kids[n] = kids[n - 1];
          --n;
        }
        kids[n] = k;
      }
    }
    top += nk;
  }
  if (counters) {
    counters->nodes += n_nodes;
    counters->texels += n_texels;
  }
  return stopped;
}

// Walks `seg` (from t0 to t1) through `pyramid`, front to back. Returns true when a visitor
// stopped the walk. `counters` (optional) are incremented.
template <class LeafVisitor, class NodeVisitor = DescendEveryNode>
bool walk_depth_image(const MinMaxPyramid& pyramid, const DepthImageSegment& seg,
                      const DepthWalkOptions& opt, LeafVisitor&& leaf, NodeVisitor&& node = {},
                      DepthWalkCounters* counters = nullptr) {
  return walk_depth_image_with_skips(pyramid, seg, opt, std::forward<LeafVisitor>(leaf),
                                     std::forward<NodeVisitor>(node), IgnoreSkips{}, counters);
}

// Rays walked together by walk_depth_image_packet.
inline constexpr int kDepthWalkPacket = 16;

namespace depth_walk_detail {

// A packet's rays, structure of arrays (lanes past the packet's size copy ray 0).
struct PacketRays {
  float px[kDepthWalkPacket], py[kDepthWalkPacket];  // p0
  float dx[kDepthWalkPacket], dy[kDepthWalkPacket], dd[kDepthWalkPacket];  // p1 - p0, d1 - d0
  float ix[kDepthWalkPacket], iy[kDepthWalkPacket], id[kDepthWalkPacket];  // their reciprocals (0 for 0)
  float d0[kDepthWalkPacket];
};
// One inner node for every ray: the rays' intervals in it, the node's widened range, its
// children's midlines.
struct PacketNodeInput {
  const float* ta;
  const float* tb;
  const float* pass;  // without min/max clipping: non-zero where the ray's depth overlaps the range
  uint32_t rays;      // the rays that walk the node (bit i: lane i)
  float lo, hi;
  float xm, ym;
  bool has_x1, has_y1;
  bool minmax_clipping;
};
// Per ray: its interval after min/max clipping, and per child c = 2 y + x its interval and
// the rays that enter it (bit i: ray i passed the node's test and its interval in child c is
// not empty).
struct PacketNodeOutput {
  float a[kDepthWalkPacket], b[kDepthWalkPacket];
  float ka[4][kDepthWalkPacket], kb[4][kDepthWalkPacket];
  uint32_t rays[4];
  float first[4];  // the smallest entry parameter over each child's rays (the packet's order)
};
// The node step of the single-ray walk (clip_axis of the depth, split_axis on both axes,
// the children's clip) for every lane at once (SIMD, depth_image_walk.cpp): the same floats.
void split_packet_node(const PacketRays& rays, const PacketNodeInput& in, PacketNodeOutput* out);

}  // namespace depth_walk_detail

// Walks up to kDepthWalkPacket segments through `pyramid` together: a packet of rays that
// share most of their nodes (the shadow rays of one receiver start at one point and fan
// out to the light, so every node from the root down to the receiver's texel is on all of
// their paths). Each node's range is read and its children are computed once for the packet;
// the per-ray arithmetic is the single-ray walk's, float for float, so every ray reaches
// exactly the texels walk_depth_image (min/max clipping as `opt`, no node visitor) gives it,
// with the same DepthWalkTexel. What differs is the order: the packet visits a node's
// children in the order of their earliest entry over its rays, so one ray's texels come
// front to back only where all rays of the packet agree; a caller must not depend on the
// order beyond "every overlapping texel once". leaf(int ray, const DepthWalkTexel&) ->
// WalkStep; Stop ends that ray only. Counters count per ray (a node tested for 5 rays
// counts 5), comparable with the single-ray walk's.
template <class LeafVisitor>
void walk_depth_image_packet(const MinMaxPyramid& pyramid, std::span<const DepthImageSegment> segs,
                             const DepthWalkOptions& opt, LeafVisitor&& leaf, DepthWalkCounters* counters = nullptr) {
  using depth_walk_detail::clip_axis;
  constexpr int K = kDepthWalkPacket;
  const int n = std::min<int>(K, static_cast<int>(segs.size()));
  if (n <= 0 || pyramid.levels() == 0) return;
  struct Entry {
    int level, x, y;
    uint32_t rays;     // bit i: ray i walks this node
    DepthRange range;  // the node's, read when it is pushed
    float ta[K], tb[K];
  };
  // Depth-first with at most 3 siblings pending per level (32 levels at most).
  Entry stack[3 * 32 + 2];
  int top = 0;
  const int W = pyramid.width(0), H = pyramid.height(0);
  const float tol = opt.tolerance;
  const int n_levels = pyramid.levels();
  constexpr int kMaxLevels = 32;
  const DepthRange* level_nodes[kMaxLevels];
  int level_width[kMaxLevels], level_height[kMaxLevels];
  for (int l = 0; l < n_levels && l < kMaxLevels; ++l) {
    level_nodes[l] = pyramid.level(l).data();
    level_width[l] = pyramid.width(l);
    level_height[l] = pyramid.height(l);
  }
  // Lanes past n copy ray 0 (finite values for the lane loops; never in a node's rays).
  depth_walk_detail::PacketRays rays;
  float* px = rays.px;
  float* py = rays.py;
  float* dx = rays.dx;
  float* dy = rays.dy;
  float* ix = rays.ix;
  float* iy = rays.iy;
  float* d0 = rays.d0;
  float* dd = rays.dd;
  float* id = rays.id;
  depth_walk_detail::PacketNodeOutput node_out;
  static constexpr auto kRayCount = [] {  // rays in a byte of a mask
    std::array<uint8_t, 256> c{};
    for (uint32_t v = 0; v < c.size(); ++v)
      for (uint32_t w = v; w; w &= w - 1) ++c[v];
    return c;
  }();
  uint64_t n_nodes = 0, n_texels = 0;
  uint32_t live = 0;  // rays not stopped
  Entry& root = stack[top++];
  root = {n_levels - 1, 0, 0, 0u, level_nodes[n_levels - 1][0], {}, {}};
  for (int i = 0; i < K; ++i) {
    const DepthImageSegment& sg = segs[i < n ? i : 0];
    px[i] = sg.p0.x, py[i] = sg.p0.y, d0[i] = sg.d0;
    dx[i] = sg.p1.x - sg.p0.x, dy[i] = sg.p1.y - sg.p0.y, dd[i] = sg.d1 - sg.d0;
    ix[i] = dx[i] != 0 ? 1.0f / dx[i] : 0.0f, iy[i] = dy[i] != 0 ? 1.0f / dy[i] : 0.0f;
    id[i] = dd[i] != 0 ? 1.0f / dd[i] : 0.0f;
    float ta = sg.t0, tb = sg.t1;
    root.ta[i] = ta;
    root.tb[i] = tb;
    if (i < n && clip_axis(px[i], dx[i], ix[i], 0, float(W), &ta, &tb) &&
        clip_axis(py[i], dy[i], iy[i], 0, float(H), &ta, &tb)) {
      root.rays |= 1u << i;
      root.ta[i] = ta;
      root.tb[i] = tb;
    }
  }
  live = root.rays;
  if (!live) top = 0;

  while (top > 0) {
    const Entry& e = stack[--top];
    uint32_t m = e.rays & live;
    if (!m) continue;
    n_nodes += static_cast<uint64_t>(kRayCount[m & 0xff] + kRayCount[(m >> 8) & 0xff]);
    if (e.level == 0) {
      const DepthRange r = e.range;
      if (r.empty()) continue;
      const int ex = e.x, ey = e.y;
      const float* cta = e.ta;
      const float* ctb = e.tb;
      for (; m; m &= m - 1) {
        const int i = __builtin_ctz(m);
        const DepthImageSegment& sg = segs[i];
        // The whole crossing of the texel, as the single-ray walk computes it.
        float la = sg.t0, lb = sg.t1;
        if (!(clip_axis(px[i], dx[i], ix[i], float(ex), float(ex + 1), &la, &lb) &&
              clip_axis(py[i], dy[i], iy[i], float(ey), float(ey + 1), &la, &lb))) {
          la = cta[i];
          lb = ctb[i];
        }
        DepthWalkTexel t;
        t.x = ex;
        t.y = ey;
        t.t_enter = la;
        t.t_exit = lb;
        t.d_enter = sg.depth_at(la);
        t.d_exit = sg.depth_at(lb);
        t.range = r;
        t.t_clip_enter = cta[i];
        t.t_clip_exit = ctb[i];
        const float dlo = std::min(t.d_enter, t.d_exit), dhi = std::max(t.d_enter, t.d_exit);
        if (!(r.lo - tol <= dhi && dlo <= r.hi + tol)) continue;
        ++n_texels;
        if (leaf(i, static_cast<const DepthWalkTexel&>(t)) == WalkStep::Stop) live &= ~(1u << i);
      }
      continue;
    }
    const DepthRange r = e.range;
    if (r.empty()) continue;
    // Each ray's part of the node (min/max clipped, agrawala2000 §5.1.1, or overlap-tested)
    // and of its children, for all lanes at once.
    depth_walk_detail::PacketNodeInput in;
    in.ta = e.ta;
    in.tb = e.tb;
    float pass[K];
    if (!opt.minmax_clipping) {
      for (int i = 0; i < K; ++i) {
        const float u = rays.d0[i] + rays.dd[i] * e.ta[i], v = rays.d0[i] + rays.dd[i] * e.tb[i];
        pass[i] = r.lo - tol <= (u < v ? v : u) && (v < u ? v : u) <= r.hi + tol;
      }
    }
    in.pass = pass;
    in.lo = r.lo - tol;
    in.hi = r.hi + tol;
    const int cl = e.level - 1, cx0 = 2 * e.x, cy0 = 2 * e.y;
    in.has_x1 = cx0 + 1 < level_width[cl];
    in.has_y1 = cy0 + 1 < level_height[cl];
    in.xm = float((cx0 + 1) << cl);
    in.ym = float((cy0 + 1) << cl);
    in.minmax_clipping = opt.minmax_clipping;
    in.rays = m;
    depth_walk_detail::PacketNodeOutput& split = node_out;
    depth_walk_detail::split_packet_node(rays, in, &split);
    const uint32_t* kin = split.rays;
    const auto& ka = split.ka;
    const auto& kb = split.kb;
    // Children in the order of their earliest entry over the packet's rays.
    int order[4], nk = 0;
    float first[4];
    for (int c = 0; c < 4; ++c) {
      if (!kin[c]) continue;
      const float f = split.first[c];
      int k = nk++;
      while (k > 0 && first[k - 1] > f) {
        first[k] = first[k - 1];
        order[k] = order[k - 1];
        --k;
      }
      first[k] = f;
      order[k] = c;
    }
    for (int k = nk - 1; k >= 0; --k) {
      const int c = order[k];
      Entry& ch = stack[top++];
      ch.level = cl;
      ch.x = cx0 + (c & 1);
      ch.y = cy0 + (c >> 1);
      ch.rays = kin[c];
      ch.range = level_nodes[cl][static_cast<size_t>(ch.y) * level_width[cl] + ch.x];
      for (int i = 0; i < K; ++i) ch.ta[i] = ka[c][i], ch.tb[i] = kb[c][i];
    }
  }
  if (counters) {
    counters->nodes += n_nodes;
    counters->texels += n_texels;
  }
}

}  // namespace penumbra
