// One shadow ray through a multilayer map (xie2007 §4.3, §5.2, §6.1) in the common subset of C++
// and GLSL (core/shader_compat.h): the ray's set-up (projected into the light-centre view,
// clipped at z_min), the receiver's own-surface band, and the leaf tests of MLSM and MTSM at a
// texel, over the shared walk (raster/depth_image_walk_shared.h). The CPU's trace
// (multilayer_trace.cpp, its single rays and its SIMD packets) and the GPU's kernels
// (kernels/mlsm_trace.comp, mtsm_trace.comp) call these functions.
#ifndef PENUMBRA_SHADOW_MULTILAYER_MULTILAYER_TRACE_SHARED_H
#define PENUMBRA_SHADOW_MULTILAYER_MULTILAYER_TRACE_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/depth_image_walk_shared.h"
#include "penumbra/raster/raster_shared.h"
#include "penumbra/shadow/multilayer/multilayer_layers_shared.h"
#include "penumbra/shadow/near_field_shared.h"

PN_SHARED_BEGIN

// What one map needs for tracing (make_trace_setup, multilayer::shared_trace_setup), 40 bytes.
struct MlTraceSetup {
  float z_thresh;          // world units of linear depth (§6.1)
  float window_tolerance;  // z_thresh as a (conservative) window-depth tolerance for node tests
  float inv_focal;         // texel world width per unit of linear depth
  float self_bias;         // texel widths at a closed receiver: the band around its own tangent plane ignored
  float stop_below;        // mtsm: a ray whose visibility falls below this is blocked (§5.2)
  float z_min;             // the map's smallest linear depth (+inf: empty)
  float open_self_bias;    // self_bias at a receiver on an open surface (a leaf, a card, a plane)
  float near_field;        // narrowest penumbra the map answers for, texel widths at the receiver (0: no near field)
  float light_width;       // near_field_light_width of the light
  float segments_held_beyond;  // CentreView's: rays are checked against the window beyond it (+inf: none)
};

// A ray ready to walk: the segment projected into the view, the receiver's normal turned toward
// the light point, and the own-surface band in world units.
struct MlRay {
  DepthProjection ps;
  vec3 n;
  float bias;
};

// Counters of traced rays (TraceCounters).
struct MlTraceCounters {
  uint rays;
  uint nodes;
  uint texels;
  uint tested;  // layers compared with a ray
  uint hits;    // layers (mtsm: estimated samples) that attenuated a ray
};

PN_SHARED_END

// Where the leaf tests read a texel's layers: the k-layer map's depths (mlsm) and the
// transparent map's layer lists (mtsm). C++: the CPU's maps; GLSL: the GPU's buffers (layouts in
// kernels/multilayer_kernels_shared.h).
#ifdef __cplusplus
#include "penumbra/raster/depth_map.h"
#include "penumbra/shadow/multilayer/transparent_layers.h"
namespace penumbra::shader {
struct MlOpaqueMapRef {
  const LayeredDepthMap* map;
};
inline int ml_opaque_count(MlOpaqueMapRef r, int x, int y) { return r.map->count(x, y); }
inline float ml_opaque_z(MlOpaqueMapRef r, int x, int y, int i) {
  return r.map->samples[r.map->index(x, y) * static_cast<size_t>(r.map->max_layers) + static_cast<size_t>(i)].z;
}
struct MlTransparentMapRef {
  const multilayer::TransparentLayerMap* map;
};
inline uint ml_transparent_first(MlTransparentMapRef r, int x, int y) { return r.map->offsets[r.map->index(x, y)]; }
inline uint ml_transparent_count(MlTransparentMapRef r, int x, int y) {
  const size_t i = r.map->index(x, y);
  return r.map->offsets[i + 1] - r.map->offsets[i];
}
inline TransparentLayer ml_transparent_layer(MlTransparentMapRef r, uint i) { return r.map->layers[i]; }
}  // namespace penumbra::shader
#else
// The GPU's k-layer map: a count per texel (uint) and k samples per texel, texel-major, 16 bytes
// each (z, window depth, opacity, triangle: gpu/raster/raster_layers_shared.h).
struct MlOpaqueMapRef {
  uint64_t counts;
  uint64_t samples;
  int width;
  int k;
};
int ml_opaque_count(MlOpaqueMapRef r, int x, int y) { return int(Uints(r.counts).v[uint(y) * uint(r.width) + uint(x)]); }
float ml_opaque_z(MlOpaqueMapRef r, int x, int y, int i) {
  uint texel = uint(y) * uint(r.width) + uint(x);
  return Floats(r.samples).v[(texel * uint(r.k) + uint(i)) * 4u];
}
// The GPU's transparent map: texel i's layers start at offsets[i] (its fragment list's start)
// and number counts[i].
layout(buffer_reference, scalar) readonly buffer MlLayersIn { TransparentLayer v[]; };
struct MlTransparentMapRef {
  uint64_t offsets;
  uint64_t counts;
  uint64_t layers;
  int width;
};
uint ml_transparent_first(MlTransparentMapRef r, int x, int y) { return Uints(r.offsets).v[uint(y) * uint(r.width) + uint(x)]; }
uint ml_transparent_count(MlTransparentMapRef r, int x, int y) { return Uints(r.counts).v[uint(y) * uint(r.width) + uint(x)]; }
TransparentLayer ml_transparent_layer(MlTransparentMapRef r, uint i) { return MlLayersIn(r.layers).v[i]; }
#endif

PN_SHARED_BEGIN

// Rays behind a full texel (kMlBeyondFullTexel, multilayer_layers_shared.h): a ray no layer
// blocks (mtsm: none takes its visibility below stop_below) that passed behind a full texel's last
// layer is kMlUnresolved: the caller traces it whole through the scene.
PN_CONST float kMlUnresolved = -1.0f;
// What a texel of the k-layer map tells a ray (ml_opaque_texel_test).
PN_CONST uint kMlTexelClear = 0u;    // no layer of the texel blocks it
PN_CONST uint kMlTexelBlocks = 1u;   // a layer blocks it
PN_CONST uint kMlTexelUnknown = 2u;  // none blocks it, and it passes behind a full texel's last layer

// Whether a ray over a texel whose pyramid range reaches up to texel_hi, its linear depths up to
// zhi, passes more than z_thresh behind the texel's last layer (linear depth z_last) where that
// texel is full.
PN_INLINE bool ml_behind_full_texel(float texel_hi, float z_last, float zhi, float z_thresh) {
  return texel_hi >= kMlBeyondFullTexel && zhi > z_last + z_thresh;
}

// The largest float below x in magnitude (nextafter toward 0) for a finite non-zero x.
PN_INLINE float ml_next_toward_zero(float x) {
  if (x == 0.0f || x != x) return x;
  return uintBitsToFloat(floatBitsToUint(x) - 1u);
}

// Whether world point x projects outside view v's window (or behind its eye).
PN_INLINE bool ml_outside_window(PN_IN(RasterView) v, vec3 x) {
  float h0, h1, h2, h3;
  view_texel_homogeneous(v, x, h0, h1, h2, h3);
  if (!(h3 > 0.0f)) return true;
  float tx = h0 / h3;
  float ty = h1 / h3;
  return !(tx >= 0.0f && ty >= 0.0f && tx <= float(v.width) && ty <= float(v.height));
}

// Whether the part of the segment from receiver p to light point q beyond linear depth z_held
// (CentreView::segments_held_beyond: casters stand only there) leaves the window. The view is
// fitted to hold those parts (multilayer.md "How it works"), up to max_fov: a view capped there (a
// light just outside a room's window, lighting walls more than 60 degrees off its axis) does not,
// and the map let such a ray through past casters it never held. The window is convex: the part's
// two ends decide.
PN_INLINE bool ml_leaves_window(PN_IN(RasterView) v, float z_held, vec3 p, vec3 q) {
  float zp = view_linear_depth(v, p);
  if (!(zp > z_held)) return false;  // no part beyond it (+inf: nothing checked)
  float zq = view_linear_depth(v, q);
  vec3 c = zq >= z_held ? q : p + (q - p) * ((zp - z_held) / (zp - zq));
  return ml_outside_window(v, p) || ml_outside_window(v, c);
}

// The near field (penumbra's addition; multilayer.md "The near field"): the fraction of the segment
// from receiver p to light point q, from p, that the caller traces through the scene itself (0 with
// no near field; 1: the whole segment): where an occluder's penumbra at p would be narrower than
// near_field texel widths at p's depth (near_field_length). There the map holds a ray's occluders
// only where they cover a texel's centre, and not inside the own-surface band; beyond, the map
// answers (ml_setup_ray starts there: with a near field it projects the segment from where the
// near field ends). 1 where the map's part of the ray leaves the window (ml_leaves_window).
PN_INLINE float ml_near_fraction(PN_IN(RasterView) v, MlTraceSetup s, vec3 p, vec3 q) {
  if (!(s.near_field > 0.0f)) return 0.0f;
  if (ml_leaves_window(v, s.segments_held_beyond, p, q)) return 1.0f;  // the map cannot answer: traced whole
  float resolved = s.near_field * max(0.0f, view_linear_depth(v, p)) * s.inv_focal;
  float dist = length(q - p);
  float near = near_field_length(resolved, dist, s.light_width);
  return near < dist ? near / dist : 1.0f;
}

// Sets up the ray from receiver p (geometric normal ng, on a closed object or not) to light point
// q. False when nothing in the map can block it (it lies entirely in front of the map's nearest
// surface, or outside the view's depth range); `blocked` is set when the receiver's own closed
// object blocks it (the light point is behind its surface). The receiver's own surface is in the
// map right where the ray starts: a layer sample X (the surface through a texel centre at depth
// z) can block the ray only if it lies on q's side of p's tangent plane by more than self_bias
// texels, dot(n, X - p) > bias, n the normal turned toward q (penumbra's rule; the paper leaves
// self-shadowing to z_thresh). A receiver on an open surface (flat per triangle: its own plane is
// exact) takes open_self_bias: a closed object's curved faces need the wider band against acne,
// while in a canopy the band is where the neighbouring leaves are (docs/methods/multilayer.md).
PN_INLINE bool ml_setup_ray(PN_IN(RasterView) v, MlTraceSetup s, vec3 p, vec3 ng, bool closed, vec3 q,
                            PN_OUT(MlRay) ray, PN_OUT(bool) blocked) {
  blocked = false;
  vec3 d = q - p;
  float side = dot(ng, d);
  ray.n = side >= 0.0f ? ng : ng * -1.0f;
  ray.bias = 0.0f;
  ray.ps.segment.p0 = vec2(0.0f, 0.0f);
  ray.ps.segment.p1 = vec2(0.0f, 0.0f);
  ray.ps.segment.d0 = 0.0f;
  ray.ps.segment.d1 = 0.0f;
  ray.ps.segment.t0 = 0.0f;
  ray.ps.segment.t1 = 1.0f;
  ray.ps.s0 = 0.0f;
  ray.ps.s1 = 1.0f;
  ray.ps.w0 = 1.0f;
  ray.ps.w1 = 1.0f;
  ray.ps.z0 = 0.0f;
  ray.ps.z1 = 0.0f;
  if (closed && !(side > 0.0f)) {
    blocked = true;  // the light point is behind the closed object's surface
    return false;
  }
  float zp = view_linear_depth(v, p);
  // With a near field the map's part of the ray starts where it ends (the whole ray near: nothing
  // left for the map).
  float f = ml_near_fraction(v, s, p, q);
  if (f >= 1.0f) return false;
  vec3 p0 = p + d * f;
  if (!(view_linear_depth(v, p0) > s.z_min)) return false;  // nothing in front (xie2007 §4.3: clip at z_min)
  if (!depth_image_project(v, p0, q, ray.ps)) return false;
  ray.bias = (closed ? s.self_bias : s.open_self_bias) * zp * s.inv_focal;
  return true;
}

// The depths z at texel (x, y) beyond the receiver's own-surface band (B z > c along the ray
// through the texel centre X(z) = o + d z, with dot(n, X - p) = A + B z), as a clip of [a, b].
PN_INLINE bool ml_clip_to_light_side(PN_IN(RasterView) v, PN_IN(MlRay) ray, vec3 p, int x, int y, PN_INOUT(float) a,
                                     PN_INOUT(float) b) {
  vec3 origin;
  vec3 dir;
  raster_texel_ray(v, float(x) + 0.5f, float(y) + 0.5f, origin, dir);
  float A = dot(ray.n, origin - p);
  float B = dot(ray.n, dir);
  float c = ray.bias - A;  // need B z > c
  if (B > 0.0f) {
    a = dw_max(a, c / B);
  } else if (B < 0.0f) {
    b = dw_min(b, c / B);
  } else if (!(0.0f > c)) {
    return false;
  }
  return a <= b;
}

// MLSM's leaf test (xie2007 §4.3, §6.1) at texel (x, y), the ray's window depths d_enter and
// d_exit over its crossing, texel_hi its pyramid range's top: whether a layer within z_thresh of
// the ray's linear depth interval (the perspective divide only here, at the leaves) blocks it, or,
// at a full texel, none does and the ray passes behind its last layer (ml_behind_full_texel).
PN_INLINE uint ml_opaque_texel_test(PN_IN(RasterView) v, MlTraceSetup s, MlOpaqueMapRef m, PN_IN(MlRay) ray, vec3 p,
                                    int x, int y, float d_enter, float d_exit, float texel_hi,
                                    PN_INOUT(uint) tested) {
  float zt = s.z_thresh;
  float zlo = view_linear_depth_from_window(v, dw_min(d_enter, d_exit));
  float zhi = view_linear_depth_from_window(v, dw_max(d_enter, d_exit));
  float a = zlo - zt;
  float b = zhi + zt;
  bool clipped = false;
  int n = ml_opaque_count(m, x, y);
  for (int i = 0; i < n; ++i) {
    tested += 1u;
    float z = ml_opaque_z(m, x, y, i);
    if (z < a || z > b) continue;
    if (!clipped) {  // the own-surface bound, once per texel and only when needed
      clipped = true;
      if (!ml_clip_to_light_side(v, ray, p, x, y, a, b)) return kMlTexelClear;  // within its own surface's band
      if (z < a || z > b) continue;
    }
    return kMlTexelBlocks;
  }
  if (n > 0 && ml_behind_full_texel(texel_hi, ml_opaque_z(m, x, y, n - 1), zhi, zt)) return kMlTexelUnknown;
  return kMlTexelClear;
}

// MTSM's leaf test (xie2007 §5.2) at texel (x, y), the ray's crossing [t_enter, t_exit] with
// window depths d_enter, d_exit: multiplies vis by what the ray crosses there; true once it falls
// below stop_below (the walk stops). Opaque layers: the MLSM rule, widened by z_thresh (so mtsm
// is mlsm on opaque scenes). Semi-transparent samples: counted where the ray's own depth interval
// over the texel holds them, half-open, unwidened: consecutive texels' intervals partition the
// ray's depths, so each surface the ray passes counts once (widened windows overlap by 2 z_thresh
// per texel and would attenuate an oblique ray crossing many texels several times over:
// penumbra's reading of §5.2's "reduce ray.vis by dv_i"). unknown is set where the ray passes
// behind a full texel's last layer (texel_hi, its pyramid range's top: ml_behind_full_texel).
PN_INLINE bool ml_transparent_texel(PN_IN(RasterView) v, MlTraceSetup s, MlTransparentMapRef m, PN_IN(MlRay) ray,
                                    vec3 p, int x, int y, float t_enter, float t_exit, float d_enter, float d_exit,
                                    float texel_hi, PN_INOUT(float) vis, PN_INOUT(bool) unknown,
                                    PN_INOUT(uint) tested, PN_INOUT(uint) hits) {
  float zt = s.z_thresh;
  float zlo = view_linear_depth_from_window(v, dw_min(d_enter, d_exit));
  float zhi = view_linear_depth_from_window(v, dw_max(d_enter, d_exit));
  float a = zlo - zt;  // opaque window
  float b = zhi + zt;
  float ta = zlo;  // transparent window
  float tb = ml_next_toward_zero(zhi);
  if (!(tb >= ta)) tb = ta;
  // The walk's texels are closed boxes: a segment running along a texel edge reaches the texels
  // on both sides with the same interval. Texel (x, y) owns [x, x+1) x [y, y+1): the crossing
  // counts transparent samples only where its midpoint is owned.
  vec2 mid = depth_segment_at(ray.ps.segment, 0.5f * (t_enter + t_exit));
  if (int(floor(mid.x)) != x || int(floor(mid.y)) != y) {
    ta = ml_inf();
    tb = -ml_inf();
  }
  bool clipped = false;
  uint first = ml_transparent_first(m, x, y);
  uint count = ml_transparent_count(m, x, y);
  for (uint i = 0u; i < count; ++i) {
    tested += 1u;
    TransparentLayer l = ml_transparent_layer(m, first + i);
    bool opaque = l.transmit <= 0.0f;
    if (opaque ? (l.z < a || l.z_first > b) : (l.z < ta || l.z_first > tb)) continue;
    if (!clipped) {  // the own-surface bound, once per texel and only when needed
      clipped = true;
      float ca = -ml_inf();
      float cb = ml_inf();
      if (!ml_clip_to_light_side(v, ray, p, x, y, ca, cb)) return false;
      a = dw_max(a, ca);
      b = dw_min(b, cb);
      ta = dw_max(ta, ca);
      tb = dw_min(tb, cb);
    }
    float unused;
    uint n = opaque ? ml_samples_in(l, a, b, unused) : ml_samples_in(l, ta, tb, unused);
    if (n == 0u) continue;
    hits += opaque ? 1u : n;
    vis = opaque ? 0.0f : vis * (n == 1u ? l.transmit : ml_pow(l.transmit, float(n)));
    if (vis < s.stop_below) return true;
  }
  if (count > 0u && ml_behind_full_texel(texel_hi, ml_transparent_layer(m, first + count - 1u).z, zhi, zt))
    unknown = true;
  return false;
}

// One ray's transmittance through a k-layer map (MLSM, xie2007 §4.3): 0 or 1, or kMlUnresolved
// where no layer blocks it and it passed behind a full texel.
PN_INLINE float ml_trace_opaque(PN_IN(RasterView) v, MlTraceSetup s, DepthPyramidRef pyr, MlOpaqueMapRef m, vec3 p,
                                vec3 ng, bool closed, vec3 q, PN_INOUT(MlTraceCounters) c) {
  c.rays += 1u;
  MlRay ray;
  bool blocked;
  if (!ml_setup_ray(v, s, p, ng, closed, q, ray, blocked)) return blocked ? 0.0f : 1.0f;
  DepthWalkState w;
  depth_walk_begin(w, pyr, ray.ps.segment, s.window_tolerance, kDepthWalkMinmax);
  bool hit = false;
  bool unknown = false;  // a later texel's layer may still block it: walk on
  DepthWalkEvent ev;
  while (depth_walk_next(w, pyr, ev) == kDepthWalkTexel) {
    uint t = ml_opaque_texel_test(v, s, m, ray, p, ev.x, ev.y, ev.d_enter, ev.d_exit, ev.range.y, c.tested);
    if (t == kMlTexelBlocks) {
      hit = true;
      break;
    }
    if (t == kMlTexelUnknown) unknown = true;
  }
  c.nodes += w.nodes;
  c.texels += w.texels;
  if (hit) c.hits += 1u;
  return hit ? 0.0f : (unknown ? kMlUnresolved : 1.0f);
}

// One ray's transmittance through a transparent map (MTSM, xie2007 §5.2): the product of the
// per-sample transmittances of the estimated samples it crosses; 0 once below stop_below;
// kMlUnresolved where it is not and the ray passed behind a full texel.
PN_INLINE float ml_trace_transparent(PN_IN(RasterView) v, MlTraceSetup s, DepthPyramidRef pyr, MlTransparentMapRef m,
                                     vec3 p, vec3 ng, bool closed, vec3 q, PN_INOUT(MlTraceCounters) c) {
  c.rays += 1u;
  MlRay ray;
  bool blocked;
  if (!ml_setup_ray(v, s, p, ng, closed, q, ray, blocked)) return blocked ? 0.0f : 1.0f;
  DepthWalkState w;
  depth_walk_begin(w, pyr, ray.ps.segment, s.window_tolerance, kDepthWalkMinmax);
  float vis = 1.0f;
  bool unknown = false;
  DepthWalkEvent ev;
  while (depth_walk_next(w, pyr, ev) == kDepthWalkTexel) {
    if (ml_transparent_texel(v, s, m, ray, p, ev.x, ev.y, ev.t_enter, ev.t_exit, ev.d_enter, ev.d_exit, ev.range.y,
                             vis, unknown, c.tested, c.hits))
      break;
  }
  c.nodes += w.nodes;
  c.texels += w.texels;
  return vis < s.stop_below ? 0.0f : (unknown ? kMlUnresolved : vis);
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::MlTraceSetup) == 40);
#endif

#endif  // PENUMBRA_SHADOW_MULTILAYER_MULTILAYER_TRACE_SHARED_H
