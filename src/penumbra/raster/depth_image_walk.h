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
#include "penumbra/raster/depth_image_walk_shared.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/raster/minmax_pyramid.h"

namespace penumbra {

// A segment in a depth image's texel space with an affine depth along it (the shared
// walk's DepthSegment, depth_image_walk_shared.h, with the CPU's conveniences).
struct DepthImageSegment {
  Vec2f p0, p1;          // texel-space points at t = 0 and t = 1
  float d0 = 0, d1 = 0;  // the ray's depth at t = 0 and t = 1 (same kind as the pyramid's)
  float t0 = 0, t1 = 1;  // the part to walk

  DepthImageSegment() = default;
  DepthImageSegment(const shader::DepthSegment& s) : p0(s.p0), p1(s.p1), d0(s.d0), d1(s.d1), t0(s.t0), t1(s.t1) {}
  shader::DepthSegment shared() const { return {p0, p1, d0, d1, t0, t1}; }

  Vec2f at(float t) const { return shader::depth_segment_at(shared(), t); }
  float depth_at(float t) const { return shader::depth_segment_depth(shared(), t); }
  // The ray's depth interval over [ta, tb] (ta <= tb).
  DepthRange depth_over(float ta, float tb) const {
    float a = depth_at(ta), b = depth_at(tb);
    return a <= b ? DepthRange{a, b} : DepthRange{b, a};
  }
  // Clips [*ta, *tb] to the closed box [x0, x1] x [y0, y1]; false when nothing is left.
  bool clip_to_box(float x0, float y0, float x1, float y1, float* ta, float* tb) const {
    return shader::depth_segment_clip_box(shared(), x0, y0, x1, y1, *ta, *tb);
  }
  // Clips [*ta, *tb] to where the depth lies in [lo, hi]; false when nothing is left.
  bool clip_to_depth(float lo, float hi, float* ta, float* tb) const {
    const float d = d1 - d0;
    return shader::dw_clip_axis(d0, d, d != 0 ? 1.0f / d : 0.0f, lo, hi, *ta, *tb);
  }
};

// A world-space segment projected into a light view (project_to_depth_image): the
// texel-space segment with window depth, and the maps back to the world segment (the shared
// DepthProjection's functions).
struct ProjectedSegment {
  DepthImageSegment segment;  // t in [0, 1]: the part in front of near and before far
  float s0 = 0, s1 = 1;       // world-segment parameters of t = 0 and t = 1
  float w0 = 1, w1 = 1;       // homogeneous w at t = 0, 1 (the linear depth; 1 for orthographic)
  float z0 = 0, z1 = 0;       // linear depth at t = 0, 1

  ProjectedSegment() = default;
  ProjectedSegment(const shader::DepthProjection& p)
      : segment(p.segment), s0(p.s0), s1(p.s1), w0(p.w0), w1(p.w1), z0(p.z0), z1(p.z1) {}
  shader::DepthProjection shared() const { return {segment.shared(), s0, s1, w0, w1, z0, z1}; }

  // How far along the world segment (0 at t = 0, 1 at t = 1) the point at t lies
  // (perspective-correct; = t for an orthographic view).
  float world_fraction(float t) const { return shader::depth_projection_world_fraction(shared(), t); }
  // The world-segment parameter s (a + s (b - a)) of the point at t.
  float world_param(float t) const { return shader::depth_projection_world_param(shared(), t); }
  // The t of world-segment parameter s (the inverse of world_param).
  float segment_param(float s) const { return shader::depth_projection_segment_param(shared(), s); }
  // Linear depth of the point at t.
  float linear_depth_at(float t) const { return shader::depth_projection_linear_depth(shared(), t); }
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
// false when nothing is left (the shared walk's clip, for the packet walk below).
inline bool clip_axis(float p, float d, float inv, float lo, float hi, float* a, float* b) {
  return shader::dw_clip_axis(p, d, inv, lo, hi, *a, *b);
}

}  // namespace depth_walk_detail

// Walks `seg` (from t0 to t1) through `pyramid`, front to back, and reports, besides the
// texels, every span of [t0, t1] it did not descend into, with the reason
// (skip(const DepthWalkSkip&), in order with the texels' clipped parts): what a caller needs
// to know where the ray passed behind or in front of the image's surfaces (agrawala2000
// §5.1.2, occlusion intervals and clear miss). Returns true when a visitor stopped the walk.
// The walk itself is depth_image_walk_shared.h's, which the GPU's kernels run too; this drives
// it with the visitors.
template <class LeafVisitor, class NodeVisitor, class SkipVisitor>
bool walk_depth_image_with_skips(const MinMaxPyramid& pyramid, const DepthImageSegment& seg,
                                 const DepthWalkOptions& opt, LeafVisitor&& leaf, NodeVisitor&& node,
                                 SkipVisitor&& skip, DepthWalkCounters* counters = nullptr) {
  constexpr bool kSkips = !std::is_same_v<std::decay_t<SkipVisitor>, IgnoreSkips>;
  constexpr bool kNodes = !std::is_same_v<std::decay_t<NodeVisitor>, DescendEveryNode>;
  const shader::DepthPyramidLevels levels(pyramid);
  shader::DepthWalkState w;
  const uint32_t flags = (opt.minmax_clipping ? shader::kDepthWalkMinmax : 0u) |
                         (kSkips ? shader::kDepthWalkSkips : 0u) | (kNodes ? shader::kDepthWalkNodes : 0u);
  shader::depth_walk_begin(w, levels, seg.shared(), opt.tolerance, flags);
  bool stopped = false;
  for (;;) {
    shader::DepthWalkEvent ev;
    const int kind = shader::depth_walk_next(w, levels, ev);
    if (kind == shader::kDepthWalkDone) break;
    if (kind == shader::kDepthWalkTexel) {
      DepthWalkTexel t;
      t.x = ev.x;
      t.y = ev.y;
      t.t_enter = ev.t_enter;
      t.t_exit = ev.t_exit;
      t.d_enter = ev.d_enter;
      t.d_exit = ev.d_exit;
      t.range = {ev.range.x, ev.range.y};
      t.t_clip_enter = ev.t_clip_enter;
      t.t_clip_exit = ev.t_clip_exit;
      if (leaf(static_cast<const DepthWalkTexel&>(t)) == WalkStep::Stop) {
        stopped = true;
        break;
      }
    } else if (kind == shader::kDepthWalkNode) {
      if constexpr (kNodes) {
        DepthWalkNode n;
        n.level = ev.level;
        n.x = ev.x;
        n.y = ev.y;
        n.t_enter = ev.t_enter;
        n.t_exit = ev.t_exit;
        n.ray = {ev.ray.x, ev.ray.y};
        n.box_ray = {ev.box_ray.x, ev.box_ray.y};
        n.range = {ev.range.x, ev.range.y};
        const NodeStep step = node(static_cast<const DepthWalkNode&>(n));
        if (step == NodeStep::Stop) {
          stopped = true;
          break;
        }
        shader::depth_walk_answer(w, levels, step == NodeStep::Descend);
      }
    } else if constexpr (kSkips) {
      skip(DepthWalkSkip{ev.t_enter, ev.t_exit, SkipReason(ev.reason), ev.level});
    }
  }
  if (counters) {
    counters->nodes += w.nodes;
    counters->texels += w.texels;
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
