// Shadow rays through reference depth images (agrawala2000 §5.1, procedure Trace, with the
// accelerations of §5.1.1-5.1.2), in the common subset of C++ and GLSL (core/shader_compat.h): the
// CPU's DepthImageTracer (depth_image_tracer.h) and the GPU's tiles (kernels/coherent_rt_tiles.comp)
// trace with these functions, over the shared walk (raster/depth_image_walk_shared.h). The images
// (floors, walls, pyramids, connectedness) and the occlusion spans live where each language keeps
// them, behind the accessors of the two branches below. The spans of one ray are three lists
// (intervals, next, walked); on the GPU each holds a fixed number and a ray that needs more sets
// `overflow` (the host grows them and traces again: never a silent drop).
#ifndef PENUMBRA_SHADOW_COHERENT_RT_DEPTH_IMAGE_TRACE_SHARED_H
#define PENUMBRA_SHADOW_COHERENT_RT_DEPTH_IMAGE_TRACE_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/depth_image_walk_shared.h"
#include "penumbra/raster/raster_shared.h"

PN_SHARED_BEGIN

// The most reference images a ray is traced through.
PN_CONST int kCrtMaxMaps = 8;
PN_CONST float kCrtLongest = 3.0e38f;  // a map's rank length when it is not finite

// TraceOptions (1: on).
struct CrtTraceOptions {
  uint minmax_clipping;
  uint connectedness;
  uint clear_miss;
  uint occlusion_intervals;
  uint ranking;
  uint hidden_blocks;
};

// TraceCounters of one or more rays (the walk's nodes and texels included); overflow: some ray's
// span lists were too small (GPU only).
struct CrtTraceCounts {
  uint rays;
  uint blocked;
  uint maps_walked;
  uint clear_misses;
  uint intervals_exhausted;
  uint connected_hits;
  uint hidden_everywhere;
  uint nodes;
  uint texels;
  uint overflow;
};

// A reference image on the device, 216 bytes (the GPU's reference images: coherent_rt_gpu.cpp).
struct CrtImageDesc {
  uint64_t floors;     // float per texel: window depth of the biased floor, +inf where empty
  uint64_t links;      // uint per texel: connected neighbours (reference_images.h's bits)
  uint64_t connected;  // uint per pyramid node (the pyramid's layout): 1 when connected
  uint64_t nodes;      // the min/max pyramid
  uint64_t levels;     // its level table
  int width;
  int height;
  int level_count;
  uint pad;
  RasterView view;
};

// The span lists.
PN_CONST int kCrtIntervals = 0;
PN_CONST int kCrtNext = 1;
PN_CONST int kCrtWalked = 2;

PN_SHARED_END

#ifdef __cplusplus
#include <vector>

#include "penumbra/shadow/coherent_rt/reference_images.h"
namespace penumbra::shader {
struct CrtImages {
  const coherent_rt::ReferenceImage* images;
  const DepthPyramidLevels* levels;  // one per image
  int count;
};
using CrtImagesRef = const CrtImages&;
inline int crt_image_count(CrtImagesRef r) { return r.count; }
inline const RasterView& crt_view(CrtImagesRef r, int k) { return r.images[k].view.shared(); }
inline DepthPyramidRef crt_pyramid(CrtImagesRef r, int k) { return r.levels[k]; }
inline int crt_width(CrtImagesRef r, int k) { return r.images[k].width; }
inline int crt_height(CrtImagesRef r, int k) { return r.images[k].height; }
inline float crt_floor(CrtImagesRef r, int k, int x, int y) { return r.images[k].floor_at(x, y); }
inline uint crt_links(CrtImagesRef r, int k, int x, int y) { return r.images[k].links_at(x, y); }
inline bool crt_node_connected(CrtImagesRef r, int k, int level, int x, int y) {
  return r.images[k].node_connected(level, x, y);
}
// The CPU's span lists grow as they need.
struct CrtSpanLists {
  std::vector<Vec2f>* lists[3];
};
using CrtSpansRef = const CrtSpanLists&;
inline vec2 crt_span(CrtSpansRef s, int list, int i) { return (*s.lists[list])[i]; }
inline bool crt_set_span(CrtSpansRef s, int list, int i, float a, float b) {
  std::vector<Vec2f>& v = *s.lists[list];
  if (static_cast<size_t>(i) >= v.size()) v.resize(static_cast<size_t>(i) + 1);
  v[i] = Vec2f(a, b);
  return true;
}
}  // namespace penumbra::shader
#else
layout(buffer_reference, scalar) readonly buffer CrtImageDescs { CrtImageDesc v[]; };
struct CrtImagesRef {
  uint64_t descs;
  int count;
};
int crt_image_count(CrtImagesRef r) { return r.count; }
RasterView crt_view(CrtImagesRef r, int k) { return CrtImageDescs(r.descs).v[k].view; }
DepthPyramidRef crt_pyramid(CrtImagesRef r, int k) {
  CrtImageDescs d = CrtImageDescs(r.descs);
  return depth_pyramid_ref(d.v[k].nodes, d.v[k].levels, d.v[k].level_count);
}
int crt_width(CrtImagesRef r, int k) { return CrtImageDescs(r.descs).v[k].width; }
int crt_height(CrtImagesRef r, int k) { return CrtImageDescs(r.descs).v[k].height; }
float crt_floor(CrtImagesRef r, int k, int x, int y) {
  CrtImageDescs d = CrtImageDescs(r.descs);
  return Floats(d.v[k].floors).v[uint(y) * uint(d.v[k].width) + uint(x)];
}
uint crt_links(CrtImagesRef r, int k, int x, int y) {
  CrtImageDescs d = CrtImageDescs(r.descs);
  return Uints(d.v[k].links).v[uint(y) * uint(d.v[k].width) + uint(x)];
}
bool crt_node_connected(CrtImagesRef r, int k, int level, int x, int y) {
  CrtImageDescs d = CrtImageDescs(r.descs);
  return Uints(d.v[k].connected).v[depth_pyramid_index(crt_pyramid(r, k), level, x, y)] != 0u;
}
// A thread's three span lists of `capacity` spans each (vec2 (a, b)), one after the other.
struct CrtSpansRef {
  uint64_t spans;
  int capacity;
};
vec2 crt_span(CrtSpansRef s, int list, int i) { return Vec2s(s.spans).v[list * s.capacity + i]; }
bool crt_set_span(CrtSpansRef s, int list, int i, float a, float b) {
  if (i >= s.capacity) return false;
  Vec2s(s.spans).v[list * s.capacity + i] = vec2(a, b);
  return true;
}
#endif

PN_SHARED_BEGIN

// The bit of the neighbour at offset (dx, dy) in {-1, 0, 1}^2 \ {(0, 0)} (reference_images.h:
// bit k for (kNeighbourDx[k], kNeighbourDy[k]) = (1,0) (-1,0) (0,1) (0,-1) (1,1) (-1,1) (1,-1)
// (-1,-1)).
PN_INLINE int crt_neighbour_bit(int dx, int dy) {
  if (dy == 0) return dx > 0 ? 0 : 1;
  if (dx == 0) return dy > 0 ? 2 : 3;
  if (dy > 0) return dx > 0 ? 4 : 5;
  return dx > 0 ? 6 : 7;
}

// std::clamp.
PN_INLINE float crt_clamp(float v, float lo, float hi) { return v < lo ? lo : (hi < v ? hi : v); }

// Appends [a, b] to a list sorted by start, merging with the last span when they touch; false
// when the list is full (GPU).
PN_INLINE bool crt_push_span(CrtSpansRef s, int list, PN_INOUT(int) count, float a, float b) {
  if (count > 0) {
    vec2 last = crt_span(s, list, count - 1);
    if (a <= last.y + 1e-6f) return crt_set_span(s, list, count - 1, last.x, dw_max(last.y, b));
  }
  if (!crt_set_span(s, list, count, a, b)) return false;
  count += 1;
  return true;
}

// Walks one image along `seg` (agrawala2000 §5.1 footnote 2, the exact test of a texel: the floor
// is hit when its depth lies in the ray's depth interval over the texel; at the texel's exit edge
// the wall to a connected neighbour is hit when the ray's depth there lies between the two
// floors). With `spans`, the parts where the ray passes behind the floors go to list `walked`
// (occlusion spans, §5.1.2). With `connectedness`, §5.1.1: the ray passes from in front of every
// surface of a connected node to behind all of them inside it, so it crosses the surface there.
// Returns 0 (no hit), 1 (a hit at segment parameter t) or 2 (a connectedness hit: no exact point).
PN_INLINE int crt_walk_map(CrtImagesRef imgs, int k, DepthSegment seg, bool minmax, bool connectedness, bool spans,
                           CrtSpansRef lists, int walked, PN_INOUT(int) walked_count, PN_OUT(float) t,
                           PN_INOUT(CrtTraceCounts) c) {
  t = 0.0f;
  float dir_x = seg.p1.x - seg.p0.x;
  float dir_y = seg.p1.y - seg.p0.y;
  int W = crt_width(imgs, k);
  int H = crt_height(imgs, k);
  uint flags = (minmax ? kDepthWalkMinmax : 0u) | (spans ? kDepthWalkSkips : 0u) | (connectedness ? kDepthWalkNodes : 0u);
  DepthPyramidRef pyr = crt_pyramid(imgs, k);
  DepthWalkState w;
  depth_walk_begin(w, pyr, seg, 0.0f, flags);
  int result = 0;
  DepthWalkEvent ev;
  for (;;) {
    int kind = depth_walk_next(w, pyr, ev);
    if (kind == kDepthWalkDone) break;
    if (kind == kDepthWalkTexel) {
      float f = crt_floor(imgs, k, ev.x, ev.y);
      float dlo = dw_min(ev.d_enter, ev.d_exit);
      float dhi = dw_max(ev.d_enter, ev.d_exit);
      if (f >= dlo && f <= dhi) {
        result = 1;
        float dd = ev.d_exit - ev.d_enter;
        t = dd != 0.0f ? crt_clamp(ev.t_enter + (f - ev.d_enter) / dd * (ev.t_exit - ev.t_enter), ev.t_enter, ev.t_exit)
                       : ev.t_enter;
        break;
      }
      if (ev.t_exit < seg.t1) {
        vec2 pe = depth_segment_at(seg, ev.t_exit);
        float edge = 1e-3f;
        int ex = dir_x > 0.0f && pe.x >= float(ev.x + 1) - edge ? 1 : (dir_x < 0.0f && pe.x <= float(ev.x) + edge ? -1 : 0);
        int ey = dir_y > 0.0f && pe.y >= float(ev.y + 1) - edge ? 1 : (dir_y < 0.0f && pe.y <= float(ev.y) + edge ? -1 : 0);
        if (ex != 0 || ey != 0) {
          int nx = ev.x + ex;
          int ny = ev.y + ey;
          if (nx >= 0 && ny >= 0 && nx < W && ny < H &&
              ((crt_links(imgs, k, ev.x, ev.y) >> uint(crt_neighbour_bit(ex, ey))) & 1u) != 0u) {
            float g = crt_floor(imgs, k, nx, ny);
            if (ev.d_exit >= dw_min(f, g) && ev.d_exit <= dw_max(f, g)) {
              result = 1;
              t = ev.t_exit;
              break;
            }
          }
        }
      }
      // No floor hit: the ray is on one side of the floor over the whole texel.
      if (spans && dlo > f && !crt_push_span(lists, walked, walked_count, ev.t_clip_enter, ev.t_clip_exit)) {
        c.overflow = 1u;
        break;
      }
    } else if (kind == kDepthWalkNode) {
      if (ev.box_ray.x <= ev.range.x && ev.box_ray.y >= ev.range.y && crt_node_connected(imgs, k, ev.level, ev.x, ev.y)) {
        result = 2;
        float dd = seg.d1 - seg.d0;
        float mid = 0.5f * (ev.range.x + ev.range.y);
        t = dd != 0.0f ? crt_clamp((mid - seg.d0) / dd, ev.t_enter, ev.t_exit) : ev.t_enter;
        break;
      }
      depth_walk_answer(w, pyr, true);
    } else if (ev.reason == kWalkSkipBehind) {
      if (!crt_push_span(lists, walked, walked_count, ev.t_enter, ev.t_exit)) {
        c.overflow = 1u;
        break;
      }
    }
  }
  c.nodes += w.nodes;
  c.texels += w.texels;
  return result;
}

// Whether the segment from p to q is blocked by the surfaces of the reference images
// (DepthImageTracer::trace): projected into every image that sees part of it, the images ranked
// by their clipped epipolar length (§5.1.2, after Chang), walked in order, each only over the
// parts of the ray hidden in all the images before (occlusion intervals); a map that sees the
// whole ray ends it (clear miss). need_point: the caller wants the blocker point (connectedness
// is then not used). A ray hidden in every image without an intersection is unblocked (§5.1.2;
// hidden_blocks: blocked).
PN_INLINE void crt_trace(CrtImagesRef imgs, CrtTraceOptions o, vec3 p, vec3 q, bool need_point, CrtSpansRef lists,
                         PN_INOUT(CrtTraceCounts) c, PN_OUT(bool) blocked, PN_OUT(bool) has_point, PN_OUT(vec3) point) {
  blocked = false;
  has_point = false;
  point = vec3(0.0f, 0.0f, 0.0f);
  int nmaps = min(kCrtMaxMaps, crt_image_count(imgs));
  DepthProjection ps[kCrtMaxMaps];
  float len[kCrtMaxMaps];
  int order[kCrtMaxMaps];
  int nvalid = 0;
  for (int k = 0; k < nmaps; ++k) {
    if (!depth_image_project(crt_view(imgs, k), p, q, ps[k])) continue;
    float ta = 0.0f;
    float tb = 1.0f;
    // A map whose image the ray misses says nothing about it.
    if (!depth_segment_clip_box(ps[k].segment, 0.0f, 0.0f, float(crt_width(imgs, k)), float(crt_height(imgs, k)), ta, tb))
      continue;
    // Ranked by the square of the clipped length (no square root: the same order, and the
    // GPU's square roots may round otherwise); a NaN (an infinite length clipped to nothing)
    // ranks last.
    PN_PRECISE float dx = ps[k].segment.p1.x - ps[k].segment.p0.x;
    PN_PRECISE float dy = ps[k].segment.p1.y - ps[k].segment.p0.y;
    PN_PRECISE float span = tb - ta;
    PN_PRECISE float len2 = (dx * dx + dy * dy) * (span * span);
    len[k] = len2 <= kCrtLongest ? len2 : kCrtLongest;
    order[nvalid] = k;
    nvalid += 1;
  }
  // §5.1.2 (after Chang): shortest clipped epipolar segment first, ties in map order. Each map's
  // rank is counted and the maps placed by it, rather than sorted by swaps: lavapipe (Mesa 22.3)
  // miscompiles a swap within a private array (the element saved before a store is read after
  // it, so the order ends up with duplicates).
  if (o.ranking != 0u) {
    int ranked[kCrtMaxMaps];
    for (int i = 0; i < nvalid; ++i) {
      int k = order[i];
      int rank = 0;
      for (int m = 0; m < nvalid; ++m) {
        float lm = len[order[m]];
        if (lm < len[k] || (lm == len[k] && m < i)) rank += 1;
      }
      ranked[rank] = k;
    }
    for (int i = 0; i < nvalid; ++i) order[i] = ranked[i];
  }
  bool connectedness = o.connectedness != 0u && !need_point;
  bool spans = o.clear_miss != 0u || o.occlusion_intervals != 0u;
  c.rays += 1u;
  // The intervals still to trace, in the world parameter s of p + s (q - p).
  int intervals = kCrtIntervals;
  int next = kCrtNext;
  int n_intervals = 0;
  crt_push_span(lists, intervals, n_intervals, 0.0f, 1.0f);
  bool whole_ray = true;  // whether the intervals are still the whole ray
  bool ended = false;     // by a clear miss or when no occlusion interval was left
  for (int i = 0; i < nvalid && !blocked; ++i) {
    int k = order[i];
    DepthProjection pk = ps[k];
    c.maps_walked += 1u;
    int n_next = 0;
    for (int v = 0; v < n_intervals; ++v) {
      vec2 iv = crt_span(lists, intervals, v);
      // The part of the interval between near and far; the rest holds no surface.
      float sa = dw_max(iv.x, pk.s0);
      float sb = dw_min(iv.y, pk.s1);
      if (sa > sb) continue;
      DepthSegment seg = pk.segment;
      seg.t0 = crt_clamp(depth_projection_segment_param(pk, sa), 0.0f, 1.0f);
      seg.t1 = crt_clamp(depth_projection_segment_param(pk, sb), 0.0f, 1.0f);
      if (seg.t0 > seg.t1) {
        float s = seg.t0;
        seg.t0 = seg.t1;
        seg.t1 = s;
      }
      int n_walked = 0;
      float t;
      int hit = crt_walk_map(imgs, k, seg, o.minmax_clipping != 0u, connectedness, spans, lists, kCrtWalked, n_walked, t, c);
      if (c.overflow != 0u) return;
      if (hit != 0) {
        blocked = true;
        has_point = hit != 2;
        point = p + (q - p) * depth_projection_world_param(pk, t);
        if (hit == 2) c.connected_hits += 1u;
        break;
      }
      // This walk's spans back to the world parameter (monotonic in t).
      for (int w = 0; w < n_walked; ++w) {
        vec2 sp = crt_span(lists, kCrtWalked, w);
        float a = depth_projection_world_param(pk, sp.x);
        float b = depth_projection_world_param(pk, sp.y);
        if (!crt_set_span(lists, next, n_next, dw_min(a, b), dw_max(a, b))) {
          c.overflow = 1u;
          return;
        }
        n_next += 1;
      }
    }
    if (blocked) break;
    if (o.occlusion_intervals != 0u) {
      if (n_next == 0) {
        if (whole_ray) {
          c.clear_misses += 1u;
        } else {
          c.intervals_exhausted += 1u;
        }
        ended = true;
        break;
      }
      int swap = intervals;
      intervals = next;
      next = swap;
      n_intervals = n_next;
      whole_ray = false;
    } else if (o.clear_miss != 0u && n_next == 0) {
      c.clear_misses += 1u;
      ended = true;
      break;
    }
  }
  // Parts of the ray hidden behind surfaces in every map and no intersection found: the paper's
  // answer is "unblocked" (§5.1.2); hidden_blocks answers "blocked" instead.
  if (!blocked && !ended && o.occlusion_intervals != 0u && nvalid > 0) {
    c.hidden_everywhere += 1u;
    if (o.hidden_blocks != 0u) {
      vec2 first = crt_span(lists, intervals, 0);
      blocked = true;
      has_point = true;
      point = p + (q - p) * (0.5f * (first.x + first.y));
    }
  }
  if (blocked) c.blocked += 1u;
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::CrtImageDesc) == 216);
#endif

#endif  // PENUMBRA_SHADOW_COHERENT_RT_DEPTH_IMAGE_TRACE_SHARED_H
