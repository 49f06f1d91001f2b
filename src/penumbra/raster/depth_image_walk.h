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
#pragma once

#include <algorithm>
#include <cstdint>
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

// The default node visitor: always descend.
struct DescendEveryNode {
  NodeStep operator()(const DepthWalkNode&) const { return NodeStep::Descend; }
};

// Walks `seg` (from t0 to t1) through `pyramid`, front to back. Returns true when a visitor
// stopped the walk. `counters` (optional) are incremented.
template <class LeafVisitor, class NodeVisitor = DescendEveryNode>
bool walk_depth_image(const MinMaxPyramid& pyramid, const DepthImageSegment& seg,
                      const DepthWalkOptions& opt, LeafVisitor&& leaf, NodeVisitor&& node = {},
                      DepthWalkCounters* counters = nullptr) {
  struct Entry {
    int level, x, y;
    float ta, tb;
  };
  // Depth-first with at most 3 siblings left pending per level: 3 * 32 + 1 entries cover any
  // image the rasterizer can make (16384^2: 15 levels).
  Entry stack[128];
  int top = 0;
  const int W = pyramid.width(0), H = pyramid.height(0);
  const float tol = opt.tolerance;
  uint64_t n_nodes = 0, n_texels = 0;
  bool stopped = false;

  float ta = seg.t0, tb = seg.t1;
  if (seg.clip_to_box(0, 0, float(W), float(H), &ta, &tb)) stack[top++] = {pyramid.levels() - 1, 0, 0, ta, tb};

  while (top > 0) {
    Entry e = stack[--top];
    ++n_nodes;
    if (e.level == 0) {
      DepthRange r = pyramid.level(0)[static_cast<size_t>(e.y) * W + e.x];
      if (r.empty()) continue;
      // The whole crossing of the texel (ancestors' clipping only removed parts where the
      // ray is outside their ranges, hence outside this texel's).
      float la = seg.t0, lb = seg.t1;
      if (!seg.clip_to_box(float(e.x), float(e.y), float(e.x + 1), float(e.y + 1), &la, &lb)) {
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
      float dlo = std::min(t.d_enter, t.d_exit), dhi = std::max(t.d_enter, t.d_exit);
      if (!(r.lo - tol <= dhi && dlo <= r.hi + tol)) continue;
      ++n_texels;
      if (leaf(static_cast<const DepthWalkTexel&>(t)) == WalkStep::Stop) {
        stopped = true;
        break;
      }
      continue;
    }
    DepthRange r = pyramid.range(e.level, e.x, e.y);
    if (r.empty()) continue;
    float a = e.ta, b = e.tb;
    DepthRange box_ray = seg.depth_over(a, b), ray = box_ray;
    if (opt.minmax_clipping) {
      // What is left lies inside the widened range by construction; testing the depths
      // again would reject single-point overlaps through rounding.
      if (!seg.clip_to_depth(r.lo - tol, r.hi + tol, &a, &b)) continue;
      ray = seg.depth_over(a, b);
      ray.lo = std::max(ray.lo, r.lo - tol);
      ray.hi = std::min(ray.hi, r.hi + tol);
    } else if (!(r.lo - tol <= ray.hi && ray.lo <= r.hi + tol)) {
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
    if (step == NodeStep::Skip) continue;
    if (step == NodeStep::Stop) {
      stopped = true;
      break;
    }
    // Children in the order the segment enters them.
    const int cl = e.level - 1, cw = pyramid.width(cl), ch = pyramid.height(cl);
    Entry kids[4];
    int nk = 0;
    for (int cy = 2 * e.y; cy < std::min(2 * e.y + 2, ch); ++cy)
      for (int cx = 2 * e.x; cx < std::min(2 * e.x + 2, cw); ++cx) {
        float x0 = float(cx << cl), y0 = float(cy << cl);
        float x1 = float(std::min(W, (cx + 1) << cl)), y1 = float(std::min(H, (cy + 1) << cl));
        float ka = a, kb = b;
        if (!seg.clip_to_box(x0, y0, x1, y1, &ka, &kb)) continue;
        Entry k{cl, cx, cy, ka, kb};
        int i = nk++;
        while (i > 0 && (kids[i - 1].ta > ka || (kids[i - 1].ta == ka && kids[i - 1].tb > kb))) {
          kids[i] = kids[i - 1];
          --i;
        }
        kids[i] = k;
      }
    for (int i = nk - 1; i >= 0; --i) stack[top++] = kids[i];
  }
  if (counters) {
    counters->nodes += n_nodes;
    counters->texels += n_texels;
  }
  return stopped;
}

}  // namespace penumbra
