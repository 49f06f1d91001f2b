// The hierarchical walk of a segment through a depth image's min/max quadtree in the common
// subset of C++ and GLSL (core/shader_compat.h): one walk for both devices. The CPU's
// walk_depth_image (raster/depth_image_walk.h, templates over visitors) and the GPU's kernels
// (mlsm, mtsm, coherent-rt: one thread per ray) drive this same state machine, so both reach the
// same texels with the same floats (agrawala2000 §5.1 procedure Trace; xie2007 §4.3).
//
// GLSL has no templates, lambdas or recursion, so the walk is an iterator: depth_walk_begin sets
// up the walk of one segment, each depth_walk_next returns its next event, front to back:
//   kDepthWalkTexel  a texel whose range overlaps the ray's depth over its crossing (the leaf
//                    test is the caller's: floors and walls, layer scans, ...);
//   kDepthWalkNode   (with kDepthWalkNodes) an inner node that passed the overlap test, before its
//                    children: the caller answers with depth_walk_answer (descend or prune) - the
//                    hook of agrawala2000 §5.1.1's hierarchical connectedness;
//   kDepthWalkSkip   (with kDepthWalkSkips) a span of the segment not walked down to texels, and
//                    why (in front of, behind, an empty node, outside the image, pruned): what
//                    occlusion intervals and clear misses need (agrawala2000 §5.1.2);
//   kDepthWalkDone.
// A caller that stops early (a blocker found) simply stops calling depth_walk_next.
//
// The arithmetic is the CPU walk's of issue 14 (docs/methods/coherent-rt.md, "Speed"): the root
// clipped to the image, a node's interval min/max-clipped to its widened range (agrawala2000
// §5.1.1), its children's intervals cut at its two midlines, children pushed sorted so the first
// entered pops first, ranges read when pushed. min and max are written as std::min and std::max
// select, PN_PRECISE keeps the GPU from fusing the clip arithmetic: the GPU's texels and t's are
// the CPU's where its division is IEEE (NVIDIA's and lavapipe's are within an ulp).
//
// What each language provides before the walk below (see the two #ifdef branches): the type
// DepthPyramidRef (a pyramid's levels) and depth_pyramid_range(p, level, x, y) -> vec2 (lo, hi),
// depth_pyramid_width(p, level), depth_pyramid_height(p, level), depth_pyramid_levels(p). The
// pyramid's layout is raster/minmax_pyramid.h's: level 0 the image, level l + 1 ceil halves of
// level l, down to 1 x 1; empty ranges are (+inf, -inf).
#ifndef PENUMBRA_RASTER_DEPTH_IMAGE_WALK_SHARED_H
#define PENUMBRA_RASTER_DEPTH_IMAGE_WALK_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/raster_shared.h"

PN_SHARED_BEGIN

// The most pyramid levels a walk handles (images up to 2^19 texels a side; the rasterizer makes
// at most 16384), and its stack: depth-first with at most 3 siblings and one deferred span
// pending per level, plus a node's two clipped-off ends while its children are pushed.
PN_CONST int kDepthWalkMaxLevels = 20;
PN_CONST int kDepthWalkStack = 4 * 20 + 4;

PN_CONST int kDepthWalkDone = 0;
PN_CONST int kDepthWalkTexel = 1;
PN_CONST int kDepthWalkNode = 2;
PN_CONST int kDepthWalkSkip = 3;

// Why a span was skipped (the C++ SkipReason's values).
PN_CONST int kWalkSkipInFront = 0;  // the ray is nearer than every surface of the node (less the tolerance)
PN_CONST int kWalkSkipBehind = 1;   // farther than every surface (plus the tolerance)
PN_CONST int kWalkSkipEmpty = 2;    // the node holds no surface
PN_CONST int kWalkSkipOutside = 3;  // outside the image
PN_CONST int kWalkSkipPruned = 4;   // the caller answered "prune" at the node

// Walk flags.
PN_CONST uint kDepthWalkMinmax = 1u;  // agrawala2000 §5.1.1 min/max clipping at every level
PN_CONST uint kDepthWalkSkips = 2u;   // report skipped spans
PN_CONST uint kDepthWalkNodes = 4u;   // report inner nodes and wait for depth_walk_answer

// A segment in a depth image's texel space, p(t) = p0 + t (p1 - p0), with an affine depth
// d(t) = d0 + t (d1 - d0) (window depth: affine along a projected segment), walked over
// [t0, t1]. 32 bytes.
struct DepthSegment {
  vec2 p0;
  vec2 p1;
  float d0;
  float d1;
  float t0;
  float t1;
};

PN_INLINE float dw_min(float a, float b) { return b < a ? b : a; }  // std::min
PN_INLINE float dw_max(float a, float b) { return a < b ? b : a; }  // std::max

PN_INLINE vec2 depth_segment_at(DepthSegment s, float t) {
  PN_PRECISE float x = s.p0.x + (s.p1.x - s.p0.x) * t;
  PN_PRECISE float y = s.p0.y + (s.p1.y - s.p0.y) * t;
  return vec2(x, y);
}
PN_INLINE float depth_segment_depth(DepthSegment s, float t) {
  PN_PRECISE float d = s.d0 + (s.d1 - s.d0) * t;
  return d;
}

// A world segment a + s (b - a), s in [0, 1], projected into a view (depth_image_project):
// the texel-space segment with window depth for t in [0, 1] (the part between near and far),
// and the maps back to the world segment. 56 bytes.
struct DepthProjection {
  DepthSegment segment;
  float s0;  // world-segment parameters of t = 0 and t = 1
  float s1;
  float w0;  // homogeneous w at t = 0, 1 (the linear depth; 1 for orthographic views)
  float w1;
  float z0;  // linear depth at t = 0, 1
  float z1;
};

// How far along the world segment (0 at t = 0, 1 at t = 1) the point at t lies
// (perspective-correct; t itself for an orthographic view).
PN_INLINE float depth_projection_world_fraction(DepthProjection p, float t) {
  PN_PRECISE float den = (1.0f - t) * p.w1 + t * p.w0;
  PN_PRECISE float f = den != 0.0f ? t * p.w0 / den : t;
  return f;
}
// The world-segment parameter s of the point at t.
PN_INLINE float depth_projection_world_param(DepthProjection p, float t) {
  PN_PRECISE float s = p.s0 + (p.s1 - p.s0) * depth_projection_world_fraction(p, t);
  return s;
}
// The t of world-segment parameter s (world_param's inverse).
PN_INLINE float depth_projection_segment_param(DepthProjection p, float s) {
  PN_PRECISE float u = p.s1 != p.s0 ? (s - p.s0) / (p.s1 - p.s0) : 0.0f;
  PN_PRECISE float den = (1.0f - u) * p.w0 + u * p.w1;
  PN_PRECISE float t = den != 0.0f ? u * p.w1 / den : u;
  return t;
}
// Linear depth of the point at t.
PN_INLINE float depth_projection_linear_depth(DepthProjection p, float t) {
  PN_PRECISE float z = p.z0 + (p.z1 - p.z0) * depth_projection_world_fraction(p, t);
  return z;
}

// LightView::window_depth and linear_depth_from_window of a view as kernels see it.
PN_INLINE float view_window_depth(PN_IN(RasterView) v, float z) {
  PN_PRECISE float d = v.perspective != 0u ? v.far * (z - v.near) / ((v.far - v.near) * z) : (z - v.near) / (v.far - v.near);
  return d;
}
PN_INLINE float view_linear_depth_from_window(PN_IN(RasterView) v, float d) {
  PN_PRECISE float z = v.perspective != 0u ? v.far * v.near / (v.far - d * (v.far - v.near)) : v.near + d * (v.far - v.near);
  return z;
}
// LightView::linear_depth.
PN_INLINE float view_linear_depth(PN_IN(RasterView) v, vec3 p) { return dot(p - v.eye, v.forward); }

// The homogeneous texel coordinates of p (LightView::texel_projection, Mat4::transform_homogeneous's
// sums): x, y, z (the linear depth), w.
PN_INLINE void view_texel_homogeneous(PN_IN(RasterView) v, vec3 world, PN_OUT(float) h0, PN_OUT(float) h1, PN_OUT(float) h2,
                                      PN_OUT(float) h3) {
  PN_PRECISE vec3 p = world - v.eye;  // texel_projection takes p - eye
  PN_PRECISE float x = v.row0.x * p.x + v.row0.y * p.y + v.row0.z * p.z + v.off0;
  PN_PRECISE float y = v.row1.x * p.x + v.row1.y * p.y + v.row1.z * p.z + v.off1;
  PN_PRECISE float z = v.row2.x * p.x + v.row2.y * p.y + v.row2.z * p.z + v.off2;
  PN_PRECISE float w = v.row3.x * p.x + v.row3.y * p.y + v.row3.z * p.z + v.off3;
  h0 = x;
  h1 = y;
  h2 = z;
  h3 = w;
}

// Projects the world segment a + s (b - a), s in [0, 1], into view v: clipped to near <= z <= far
// homogeneously (nothing behind the eye is mirrored), the texel-space segment with window depth.
// Not clipped to the image: the walk does that. False when no part lies between near and far.
PN_INLINE bool depth_image_project(PN_IN(RasterView) v, vec3 a, vec3 b, PN_OUT(DepthProjection) proj) {
  float a0, a1, a2, a3, b0, b1, b2, b3;
  view_texel_homogeneous(v, a, a0, a1, a2, a3);
  view_texel_homogeneous(v, b, b0, b1, b2, b3);
  proj.segment.p0 = vec2(0.0f, 0.0f);
  proj.segment.p1 = vec2(0.0f, 0.0f);
  proj.segment.d0 = 0.0f;
  proj.segment.d1 = 0.0f;
  proj.segment.t0 = 0.0f;
  proj.segment.t1 = 1.0f;
  proj.s0 = 0.0f;
  proj.s1 = 1.0f;
  proj.w0 = 1.0f;
  proj.w1 = 1.0f;
  proj.z0 = 0.0f;
  proj.z1 = 0.0f;
  // Row 2 is the linear depth, affine in the world parameter s: clip s to [near, far].
  float s0 = 0.0f;
  float s1 = 1.0f;
  PN_PRECISE float dz = b2 - a2;
  if (dz == 0.0f) {
    if (a2 < v.near || a2 > v.far) return false;
  } else {
    PN_PRECISE float sa = (v.near - a2) / dz;
    PN_PRECISE float sb = (v.far - a2) / dz;
    if (sa > sb) {
      float t = sa;
      sa = sb;
      sb = t;
    }
    s0 = dw_max(s0, sa);
    s1 = dw_min(s1, sb);
    if (s0 > s1) return false;
  }
  PN_PRECISE float x0 = a0 + (b0 - a0) * s0;
  PN_PRECISE float y0 = a1 + (b1 - a1) * s0;
  PN_PRECISE float z0 = a2 + (b2 - a2) * s0;
  PN_PRECISE float x1 = a0 + (b0 - a0) * s1;
  PN_PRECISE float y1 = a1 + (b1 - a1) * s1;
  PN_PRECISE float z1 = a2 + (b2 - a2) * s1;
  // Clipping can leave a depth a rounding error outside [near, far]; w stays positive.
  z0 = dw_min(dw_max(z0, v.near), v.far);
  z1 = dw_min(dw_max(z1, v.near), v.far);
  float w0 = v.perspective != 0u ? z0 : 1.0f;
  float w1 = v.perspective != 0u ? z1 : 1.0f;
  PN_PRECISE float px0 = x0 / w0;
  PN_PRECISE float py0 = y0 / w0;
  PN_PRECISE float px1 = x1 / w1;
  PN_PRECISE float py1 = y1 / w1;
  proj.segment.p0 = vec2(px0, py0);
  proj.segment.p1 = vec2(px1, py1);
  proj.segment.d0 = view_window_depth(v, z0);
  proj.segment.d1 = view_window_depth(v, z1);
  proj.s0 = s0;
  proj.s1 = s1;
  proj.w0 = w0;
  proj.w1 = w1;
  proj.z0 = z0;
  proj.z1 = z1;
  return true;
}

// One level of a pyramid on the device, 16 bytes (gpu/minmax_pyramid_gpu.h writes the table): its
// first node in the nodes buffer and its size.
struct DepthPyramidLevel {
  uint offset;
  int width;
  int height;
  uint pad;
};

// One entry of the walk's stack: a node to visit (level >= 0) with the segment's interval in it
// and the node's range (read when pushed), or a deferred skipped span (level -1, x: the reason,
// y: the level of the node it belongs to). 28 bytes.
struct DepthWalkEntry {
  int level;
  int x;
  int y;
  float ta;
  float tb;
  float lo;
  float hi;
};

// What depth_walk_next reports.
struct DepthWalkEvent {
  int kind;  // kDepthWalkTexel, kDepthWalkNode, kDepthWalkSkip (kDepthWalkDone: nothing)
  int level;
  int x;
  int y;
  // Texel: the segment's crossing of the (closed) texel inside [t0, t1], and the ray's depth at
  // both ends. Node: its interval after box (and, with min/max clipping, depth) clipping.
  // Skip: the span skipped.
  float t_enter;
  float t_exit;
  float d_enter;
  float d_exit;
  vec2 range;  // the node's or texel's (lo, hi)
  // Texel: the part of the crossing the ancestors' min/max clipping left (the occlusion spans
  // of agrawala2000 §5.1.2 tile [t0, t1] with the skipped spans).
  float t_clip_enter;
  float t_clip_exit;
  // Node: the ray's depth over the clipped interval, and over the node's whole box crossing
  // (as far as the ancestors' clipping left it: hierarchical connectedness, §5.1.1).
  vec2 ray;
  vec2 box_ray;
  int reason;  // Skip: kWalkSkip*
};

// One walk in progress, less its stack (DepthWalkState below: in C++ this with the stack, in GLSL
// this alone, the stack a private array of the invocation, so that passing the state to the walk's
// functions never copies the stack).
struct DepthWalkScalars {
  DepthSegment seg;
  float dx;  // p1 - p0 and d1 - d0, and their reciprocals (0 for 0)
  float dy;
  float dd;
  float ix;
  float iy;
  float id;
  float tol;
  uint flags;
  int top;
  uint nodes;   // entries popped (inner nodes and texels), overlap-tested
  uint texels;  // texels reported
  DepthWalkEntry pending;  // the node last reported as kDepthWalkNode
  float pending_a;
  float pending_b;
};

PN_SHARED_END

// A pyramid's levels as the walk reads them (DepthPyramidRef, depth_pyramid_*): in C++ the
// MinMaxPyramid's level arrays; in GLSL a buffer of vec2 (lo, hi) per node, level 0 first, each
// level row-major right after the one below it, and a table of the levels
// (gpu/minmax_pyramid_gpu.h): small enough to pass around without copying arrays.
#ifdef __cplusplus
#include "penumbra/core/error.h"
#include "penumbra/raster/minmax_pyramid.h"
namespace penumbra::shader {
struct DepthPyramidLevels {
  const DepthRange* nodes[kDepthWalkMaxLevels];
  int width[kDepthWalkMaxLevels];
  int height[kDepthWalkMaxLevels];
  int levels = 0;
  explicit DepthPyramidLevels(const MinMaxPyramid& p) : levels(p.levels()) {
    if (levels > kDepthWalkMaxLevels)
      throw Error("depth image walk: a pyramid of {} levels is more than the {} a walk handles", levels,
                  kDepthWalkMaxLevels);
    for (int l = 0; l < levels; ++l) {
      nodes[l] = p.level(l).data();
      width[l] = p.width(l);
      height[l] = p.height(l);
    }
  }
};
using DepthPyramidRef = const DepthPyramidLevels&;
inline vec2 depth_pyramid_range(DepthPyramidRef p, int level, int x, int y) {
  const DepthRange r = p.nodes[level][static_cast<size_t>(y) * static_cast<size_t>(p.width[level]) + static_cast<size_t>(x)];
  return vec2(r.lo, r.hi);
}
inline int depth_pyramid_width(DepthPyramidRef p, int level) { return p.width[level]; }
inline int depth_pyramid_height(DepthPyramidRef p, int level) { return p.height[level]; }
inline int depth_pyramid_levels(DepthPyramidRef p) { return p.levels; }
struct DepthWalkState : DepthWalkScalars {
  DepthWalkEntry stack[kDepthWalkStack];
};
inline DepthWalkEntry dw_entry(const DepthWalkState& w, int i) { return w.stack[i]; }
inline void dw_set_entry(DepthWalkState& w, int i, const DepthWalkEntry& e) { w.stack[i] = e; }
}  // namespace penumbra::shader
#else
// A pyramid on the device: its nodes (vec2 (lo, hi) each, every level) and its level table
// (DepthPyramidLevel per level, level 0 first), both device addresses.
layout(buffer_reference, scalar) readonly buffer DepthPyramidLevels { DepthPyramidLevel v[]; };
struct DepthPyramidRef {
  uint64_t nodes;
  uint64_t levels;
  int count;
};
DepthPyramidRef depth_pyramid_ref(uint64_t nodes, uint64_t levels, int count) {
  DepthPyramidRef p;
  p.nodes = nodes;
  p.levels = levels;
  p.count = count;
  return p;
}
// Node (x, y) of `level`'s index in the nodes.
uint depth_pyramid_index(DepthPyramidRef p, int level, int x, int y) {
  DepthPyramidLevel l = DepthPyramidLevels(p.levels).v[level];
  return l.offset + uint(y) * uint(l.width) + uint(x);
}
vec2 depth_pyramid_range(DepthPyramidRef p, int level, int x, int y) {
  return Vec2s(p.nodes).v[depth_pyramid_index(p, level, x, y)];
}
int depth_pyramid_width(DepthPyramidRef p, int level) { return DepthPyramidLevels(p.levels).v[level].width; }
int depth_pyramid_height(DepthPyramidRef p, int level) { return DepthPyramidLevels(p.levels).v[level].height; }
int depth_pyramid_levels(DepthPyramidRef p) { return p.count; }
// One walk at a time per invocation: its stack.
DepthWalkEntry g_depth_walk_stack[kDepthWalkStack];
#define DepthWalkState DepthWalkScalars
DepthWalkEntry dw_entry(DepthWalkState w, int i) { return g_depth_walk_stack[i]; }
void dw_set_entry(DepthWalkState w, int i, DepthWalkEntry e) { g_depth_walk_stack[i] = e; }
#endif

PN_SHARED_BEGIN

// Clips [a, b] to where p + t d lies in [lo, hi] (inv = 1 / d, or anything when d = 0); false
// when nothing is left.
PN_INLINE bool dw_clip_axis(float p, float d, float inv, float lo, float hi, PN_INOUT(float) a, PN_INOUT(float) b) {
  if (d == 0.0f) return p >= lo && p <= hi && a <= b;
  PN_PRECISE float u = (lo - p) * inv;
  PN_PRECISE float v = (hi - p) * inv;
  if (u > v) {
    float t = u;
    u = v;
    v = t;
  }
  a = dw_max(a, u);
  b = dw_min(b, v);
  return a <= b;
}

// Clips [ta, tb] to the closed box [x0, x1] x [y0, y1] (DepthImageSegment::clip_to_box); false when
// nothing is left.
PN_INLINE bool depth_segment_clip_box(DepthSegment s, float x0, float y0, float x1, float y1, PN_INOUT(float) ta,
                                      PN_INOUT(float) tb) {
  float dx = s.p1.x - s.p0.x;
  float dy = s.p1.y - s.p0.y;
  return dw_clip_axis(s.p0.x, dx, dx != 0.0f ? 1.0f / dx : 0.0f, x0, x1, ta, tb) &&
         dw_clip_axis(s.p0.y, dy, dy != 0.0f ? 1.0f / dy : 0.0f, y0, y1, ta, tb);
}

PN_INLINE bool dw_clip_box(PN_IN(DepthWalkState) w, float x0, float y0, float x1, float y1, PN_INOUT(float) a,
                           PN_INOUT(float) b) {
  return dw_clip_axis(w.seg.p0.x, w.dx, w.ix, x0, x1, a, b) && dw_clip_axis(w.seg.p0.y, w.dy, w.iy, y0, y1, a, b);
}

PN_INLINE float dw_depth_at(PN_IN(DepthWalkState) w, float t) {
  PN_PRECISE float d = w.seg.d0 + w.dd * t;
  return d;
}

// The ray's depth interval over [ta, tb] (ta <= tb).
PN_INLINE vec2 dw_depth_over(PN_IN(DepthWalkState) w, float ta, float tb) {
  float a = dw_depth_at(w, ta);
  float b = dw_depth_at(w, tb);
  return a <= b ? vec2(a, b) : vec2(b, a);
}

// Which side of range r the ray is on at t (it lies outside the widened range there).
PN_INLINE int dw_side(PN_IN(DepthWalkState) w, float t, vec2 r) {
  return dw_depth_at(w, t) < 0.5f * (r.x + r.y) ? kWalkSkipInFront : kWalkSkipBehind;
}

PN_INLINE void dw_push(PN_INOUT(DepthWalkState) w, int level, int x, int y, float ta, float tb, vec2 r) {
  DepthWalkEntry e;
  e.level = level;
  e.x = x;
  e.y = y;
  e.ta = ta;
  e.tb = tb;
  e.lo = r.x;
  e.hi = r.y;
  dw_set_entry(w, w.top, e);
  w.top += 1;
}

// The two halves of a node's interval [a, b] on one axis, cut at the midline m between its
// children (lo0/hi0 the lower half, lo1/hi1 the upper): the one part of a clip against each
// child's range the node's own clip has not applied (the child shares the node's other edge), so
// the same floats as clipping to the child's whole box. in0/in1 are cleared for a half the
// segment misses when it runs parallel to the axis.
PN_INLINE void dw_split_axis(float p, float d, float inv, float m, float a, float b, PN_INOUT(float) lo0,
                             PN_INOUT(float) hi0, PN_INOUT(float) lo1, PN_INOUT(float) hi1, PN_INOUT(bool) in0,
                             PN_INOUT(bool) in1) {
  if (d == 0.0f) {
    in0 = in0 && p <= m;
    in1 = in1 && p >= m;
    return;
  }
  PN_PRECISE float t = (m - p) * inv;
  if (d > 0.0f) {
    hi0 = dw_min(b, t);
    lo1 = dw_max(a, t);
  } else {
    lo0 = dw_max(a, t);
    hi1 = dw_min(b, t);
  }
}

// Pushes the children of inner node e (its interval [a, b] clipped) in the order the segment
// enters them, the first entered on top (by (ta, tb); among equal ones the first in y-then-x
// order), with the node's clipped-off ends as deferred skips around them.
PN_INLINE void dw_descend(PN_INOUT(DepthWalkState) w, DepthPyramidRef pyr, DepthWalkEntry e, float a, float b) {
  bool skips = (w.flags & kDepthWalkSkips) != 0u;
  vec2 r = vec2(e.lo, e.hi);
  // The clipped-off end after the children pops after them.
  if (skips && b < e.tb) dw_push(w, -1, dw_side(w, e.tb, r), e.level, b, e.tb, vec2(0.0f, 0.0f));
  int cl = e.level - 1;
  int cx0 = 2 * e.x;
  int cy0 = 2 * e.y;
  bool has_x1 = cx0 + 1 < depth_pyramid_width(pyr, cl);
  bool has_y1 = cy0 + 1 < depth_pyramid_height(pyr, cl);
  float xa0 = a;
  float xa1 = a;
  float xb0 = b;
  float xb1 = b;
  float ya0 = a;
  float ya1 = a;
  float yb0 = b;
  float yb1 = b;
  bool xin0 = true;
  bool xin1 = has_x1;
  bool yin0 = true;
  bool yin1 = has_y1;
  if (has_x1) dw_split_axis(w.seg.p0.x, w.dx, w.ix, float((cx0 + 1) << cl), a, b, xa0, xb0, xa1, xb1, xin0, xin1);
  if (has_y1) dw_split_axis(w.seg.p0.y, w.dy, w.iy, float((cy0 + 1) << cl), a, b, ya0, yb0, ya1, yb1, yin0, yin1);
  int base = w.top;
  int nk = 0;
  for (int j = 0; j < 2; ++j) {
    if (!(j == 0 ? yin0 : yin1)) continue;
    float ya = j == 0 ? ya0 : ya1;
    float yb = j == 0 ? yb0 : yb1;
    for (int i = 0; i < 2; ++i) {
      if (!(i == 0 ? xin0 : xin1)) continue;
      float ka = dw_max(i == 0 ? xa0 : xa1, ya);
      float kb = dw_min(i == 0 ? xb0 : xb1, yb);
      if (!(ka <= kb)) continue;
      vec2 kr = depth_pyramid_range(pyr, cl, cx0 + i, cy0 + j);
      DepthWalkEntry k;
      k.level = cl;
      k.x = cx0 + i;
      k.y = cy0 + j;
      k.ta = ka;
      k.tb = kb;
      k.lo = kr.x;
      k.hi = kr.y;
      // Sorted straight into the stack, last to enter first.
      int n = nk;
      nk += 1;
      while (n > 0) {
        DepthWalkEntry before = dw_entry(w, base + n - 1);
        if (!(before.ta < ka || (before.ta == ka && before.tb <= kb))) break;
        dw_set_entry(w, base + n, before);
        n -= 1;
      }
      dw_set_entry(w, base + n, k);
    }
  }
  w.top = base + nk;
  // The clipped-off end before the children pops first.
  if (skips && a > e.ta) dw_push(w, -1, dw_side(w, e.ta, r), e.level, e.ta, a, vec2(0.0f, 0.0f));
}

// Starts the walk of `seg` (from seg.t0 to seg.t1) through `pyr`: node ranges are widened by
// `tolerance` on both sides in the overlap tests and the min/max clipping; `flags` as above.
PN_INLINE void depth_walk_begin(PN_OUT(DepthWalkState) w, DepthPyramidRef pyr, DepthSegment seg, float tolerance,
                                uint flags) {
  w.seg = seg;
  w.dx = seg.p1.x - seg.p0.x;
  w.dy = seg.p1.y - seg.p0.y;
  w.dd = seg.d1 - seg.d0;
  w.ix = w.dx != 0.0f ? 1.0f / w.dx : 0.0f;
  w.iy = w.dy != 0.0f ? 1.0f / w.dy : 0.0f;
  w.id = w.dd != 0.0f ? 1.0f / w.dd : 0.0f;
  w.tol = tolerance;
  w.flags = flags;
  w.top = 0;
  w.nodes = 0u;
  w.texels = 0u;
  w.pending.level = 0;
  w.pending.x = 0;
  w.pending.y = 0;
  w.pending.ta = 0.0f;
  w.pending.tb = 0.0f;
  w.pending.lo = 0.0f;
  w.pending.hi = 0.0f;
  w.pending_a = 0.0f;
  w.pending_b = 0.0f;
  bool skips = (flags & kDepthWalkSkips) != 0u;
  int levels = depth_pyramid_levels(pyr);
  if (levels <= 0) {
    if (skips) dw_push(w, -1, kWalkSkipOutside, -1, seg.t0, seg.t1, vec2(0.0f, 0.0f));
    return;
  }
  float ta = seg.t0;
  float tb = seg.t1;
  if (dw_clip_box(w, 0.0f, 0.0f, float(depth_pyramid_width(pyr, 0)), float(depth_pyramid_height(pyr, 0)), ta, tb)) {
    // Pushed in reverse: the part before the image, the root, the part after it.
    if (skips && tb < seg.t1) dw_push(w, -1, kWalkSkipOutside, -1, tb, seg.t1, vec2(0.0f, 0.0f));
    dw_push(w, levels - 1, 0, 0, ta, tb, depth_pyramid_range(pyr, levels - 1, 0, 0));
    if (skips && ta > seg.t0) dw_push(w, -1, kWalkSkipOutside, -1, seg.t0, ta, vec2(0.0f, 0.0f));
  } else if (skips) {
    dw_push(w, -1, kWalkSkipOutside, -1, seg.t0, seg.t1, vec2(0.0f, 0.0f));
  }
}

PN_INLINE void dw_skip_event(PN_OUT(DepthWalkEvent) ev, float ta, float tb, int reason, int level) {
  ev.kind = kDepthWalkSkip;
  ev.level = level;
  ev.x = 0;
  ev.y = 0;
  ev.t_enter = ta;
  ev.t_exit = tb;
  ev.d_enter = 0.0f;
  ev.d_exit = 0.0f;
  ev.range = vec2(0.0f, 0.0f);
  ev.t_clip_enter = ta;
  ev.t_clip_exit = tb;
  ev.ray = vec2(0.0f, 0.0f);
  ev.box_ray = vec2(0.0f, 0.0f);
  ev.reason = reason;
}

// The walk's next event (kDepthWalkDone when it is over). Skipped spans are events only with
// kDepthWalkSkips, inner nodes only with kDepthWalkNodes (then the walk waits for
// depth_walk_answer before it goes on).
PN_INLINE int depth_walk_next(PN_INOUT(DepthWalkState) w, DepthPyramidRef pyr, PN_OUT(DepthWalkEvent) ev) {
  bool skips = (w.flags & kDepthWalkSkips) != 0u;
  while (w.top > 0) {
    w.top -= 1;
    DepthWalkEntry e = dw_entry(w, w.top);
    if (e.level < 0) {
      dw_skip_event(ev, e.ta, e.tb, e.x, e.y);
      return kDepthWalkSkip;
    }
    w.nodes += 1u;
    vec2 r = vec2(e.lo, e.hi);
    if (r.x > r.y) {  // empty
      if (skips) {
        dw_skip_event(ev, e.ta, e.tb, kWalkSkipEmpty, e.level);
        return kDepthWalkSkip;
      }
      continue;
    }
    if (e.level == 0) {
      // The whole crossing of the texel (ancestors' clipping only removed parts where the ray is
      // outside their ranges, hence outside this texel's).
      float la = w.seg.t0;
      float lb = w.seg.t1;
      if (!dw_clip_box(w, float(e.x), float(e.y), float(e.x + 1), float(e.y + 1), la, lb)) {
        la = e.ta;  // rounding: keep what the parent passed down
        lb = e.tb;
      }
      float d_enter = dw_depth_at(w, la);
      float d_exit = dw_depth_at(w, lb);
      float dlo = dw_min(d_enter, d_exit);
      float dhi = dw_max(d_enter, d_exit);
      if (!(r.x - w.tol <= dhi && dlo <= r.y + w.tol)) {
        if (skips) {
          dw_skip_event(ev, e.ta, e.tb, dw_side(w, 0.5f * (e.ta + e.tb), r), 0);
          return kDepthWalkSkip;
        }
        continue;
      }
      w.texels += 1u;
      ev.kind = kDepthWalkTexel;
      ev.level = 0;
      ev.x = e.x;
      ev.y = e.y;
      ev.t_enter = la;
      ev.t_exit = lb;
      ev.d_enter = d_enter;
      ev.d_exit = d_exit;
      ev.range = r;
      ev.t_clip_enter = e.ta;
      ev.t_clip_exit = e.tb;
      ev.ray = vec2(dlo, dhi);
      ev.box_ray = vec2(dlo, dhi);
      ev.reason = 0;
      return kDepthWalkTexel;
    }
    float a = e.ta;
    float b = e.tb;
    vec2 box_ray = dw_depth_over(w, a, b);
    vec2 ray = box_ray;
    if ((w.flags & kDepthWalkMinmax) != 0u) {
      // What is left lies inside the widened range by construction; testing the depths again
      // would reject single-point overlaps through rounding.
      if (!dw_clip_axis(w.seg.d0, w.dd, w.id, r.x - w.tol, r.y + w.tol, a, b)) {
        if (skips) {
          dw_skip_event(ev, e.ta, e.tb, dw_side(w, 0.5f * (e.ta + e.tb), r), e.level);
          return kDepthWalkSkip;
        }
        continue;
      }
      ray = dw_depth_over(w, a, b);
      ray.x = dw_max(ray.x, r.x - w.tol);
      ray.y = dw_min(ray.y, r.y + w.tol);
    } else if (!(r.x - w.tol <= ray.y && ray.x <= r.y + w.tol)) {
      if (skips) {
        dw_skip_event(ev, e.ta, e.tb, dw_side(w, 0.5f * (e.ta + e.tb), r), e.level);
        return kDepthWalkSkip;
      }
      continue;
    }
    if ((w.flags & kDepthWalkNodes) != 0u) {
      w.pending = e;
      w.pending_a = a;
      w.pending_b = b;
      ev.kind = kDepthWalkNode;
      ev.level = e.level;
      ev.x = e.x;
      ev.y = e.y;
      ev.t_enter = a;
      ev.t_exit = b;
      ev.d_enter = 0.0f;
      ev.d_exit = 0.0f;
      ev.range = r;
      ev.t_clip_enter = e.ta;
      ev.t_clip_exit = e.tb;
      ev.ray = ray;
      ev.box_ray = box_ray;
      ev.reason = 0;
      return kDepthWalkNode;
    }
    dw_descend(w, pyr, e, a, b);
  }
  ev.kind = kDepthWalkDone;
  return kDepthWalkDone;
}

// The caller's answer to a kDepthWalkNode event: descend into its children, or prune it (a
// kWalkSkipPruned span with kDepthWalkSkips).
PN_INLINE void depth_walk_answer(PN_INOUT(DepthWalkState) w, DepthPyramidRef pyr, bool descend) {
  DepthWalkEntry e = w.pending;
  if (descend) {
    dw_descend(w, pyr, e, w.pending_a, w.pending_b);
  } else if ((w.flags & kDepthWalkSkips) != 0u) {
    dw_push(w, -1, kWalkSkipPruned, e.level, e.ta, e.tb, vec2(0.0f, 0.0f));
  }
}

PN_SHARED_END

#endif  // PENUMBRA_RASTER_DEPTH_IMAGE_WALK_SHARED_H
