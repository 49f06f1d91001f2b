// ssv-rt's per-point and per-edge math (Laine et al. 2005 §3.2), shared by the CPU version
// (depth_complexity.cpp, soft_shadow_volumes.cpp) and its GPU kernel (kernels/ssv_evaluate.comp),
// in the C++/GLSL subset of core/shader_compat.h, and the GPU version's buffer layouts.
#ifndef PENUMBRA_SHADOW_SSV_SHARED_H
#define PENUMBRA_SHADOW_SSV_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// The four linear tests of one edge, relative to the point o (depth_complexity.h): a light
// sample l (relative to o) crosses iff m . l < 0, u . l - ua > 0 and (alpha . l) (beta . l) < 0;
// the samples that cross change their depth complexity by `delta`.
struct SsvCrossing {
  vec3 m;
  float ua;
  vec3 u;
  int delta;
  vec3 alpha;
  float pad0;
  vec3 beta;
  float pad1;
};

// §3.2 per edge a-b (third vertices w0, w1 of its `triangles` triangles) seen from o, with the
// reference sample r (relative to o): the edge's k_e from the plane (o, a, b) (each triangle adds
// the side of its third vertex), and the tests oriented so that r is on the positive side of
// each. In double: the small triangles of a fine mesh seen from afar make the cross products
// cancel in float. False where the edge changes nothing from o (k_e = 0, or r on its plane).
PN_INLINE bool ssv_edge_crossing(vec3 ea, vec3 eb, vec3 w0, vec3 w1, uint triangles, vec3 o, vec3 r,
                                 PN_OUT(SsvCrossing) c) {
  dvec3 a = dvec3(ea) - dvec3(o), b = dvec3(eb) - dvec3(o), rr = dvec3(r);
  dvec3 m = cross(a, b);
  int k = 0;
  for (uint t = 0u; t < triangles; ++t) {
    double s = dot(m, dvec3(t == 0u ? w0 : w1) - dvec3(o));
    k += (s > double(0.0f) ? 1 : 0) - (s < double(0.0f) ? 1 : 0);
  }
  double side_r = dot(m, rr);
  c.m = vec3(0.0f, 0.0f, 0.0f);
  c.u = c.m;
  c.alpha = c.m;
  c.beta = c.m;
  c.ua = 0.0f;
  c.delta = 0;
  c.pad0 = 0.0f;
  c.pad1 = 0.0f;
  if (k == 0 || side_r == double(0.0f)) return false;
  // A crossing sample has m . l < 0, u . l > u . a (the line a-b on o's side of r-l: det[b - a,
  // r - a, l - a] has the sign of det[b - a, o - a, r - a] = m . r) and (a x r) . l, (b x r) . l
  // of opposite signs (a and b on either side of the plane (o, r, l)).
  double sgn = side_r > double(0.0f) ? double(1.0f) : double(-1.0f);
  m = m * sgn;
  dvec3 u = cross(b - a, rr - a) * sgn;
  double ua = dot(u, a);
  dvec3 alpha = cross(a, rr), beta = cross(b, rr);
  // Sweeping from r over the edge onto m's negative side enters the triangles there and leaves
  // those on the positive side: D changes by -k (k counted with the unflipped m).
  c.delta = side_r > double(0.0f) ? -k : k;
  c.m = vec3(float(m.x), float(m.y), float(m.z));
  c.u = vec3(float(u.x), float(u.y), float(u.z));
  c.alpha = vec3(float(alpha.x), float(alpha.y), float(alpha.z));
  c.beta = vec3(float(beta.x), float(beta.y), float(beta.z));
  c.ua = float(ua);
  return true;
}

// One light sample l (relative to o) against an edge's tests, in float with every product and
// sum rounded as crossing_kernel.cpp's SIMD loop rounds them (no fused multiply-adds).
PN_INLINE bool ssv_sample_crosses(SsvCrossing c, vec3 l) {
  PN_PRECISE float s = (c.m.x * l.x + c.m.y * l.y) + c.m.z * l.z;
  PN_PRECISE float t = ((c.u.x * l.x + c.u.y * l.y) + c.u.z * l.z) - c.ua;
  PN_PRECISE float pa = (c.alpha.x * l.x + c.alpha.y * l.y) + c.alpha.z * l.z;
  PN_PRECISE float pb = (c.beta.x * l.x + c.beta.y * l.y) + c.beta.z * l.z;
  PN_PRECISE float pab = pa * pb;
  return s < 0.0f && t > 0.0f && pab < 0.0f;
}

// §3.2's quick test that an edge of two triangles (planes n_i . x + d_i, |n_i| = scale_i) is
// surely no silhouette from o: o in front of one plane and behind the other, both by more than
// the rounding of the test. o_size: max |coordinate| of o.
PN_INLINE bool ssv_surely_not_silhouette(vec3 n0, float d0, float scale0, vec3 n1, float d1, float scale1, vec3 o,
                                         float o_size) {
  float s0 = dot(n0, o) + d0, s1 = dot(n1, o) + d1;
  const float kRelative = 1e-5f;
  float t0 = kRelative * (scale0 * (3.0f * o_size) + abs(d0));
  float t1 = kRelative * (scale1 * (3.0f * o_size) + abs(d1));
  return (s0 > t0 && s1 < -t1) || (s0 < -t0 && s1 > t1);
}

// Whether o sees every triangle of a hierarchy node from the same side (soft_shadow_volumes.cpp
// NodeFacing: unit normals within `spread` of `axis`, points in a box with centre `centre`,
// half-diagonal `half_diagonal`, axis . x in [h_lo, h_hi]), with a margin far above the
// rounding: then no edge of the node is a silhouette from o.
PN_INLINE bool ssv_sees_all_alike(vec3 axis, float spread, float h_lo, float h_hi, vec3 centre, float half_diagonal,
                                  vec3 o) {
  float reach = length(o - centre) + half_diagonal;
  float ao = dot(axis, o);
  float margin = 1e-4f * (reach + abs(ao) + 1.0f);
  return ao - h_hi - spread * reach > margin || ao - h_lo + spread * reach < -margin;
}

// ---------------------------------------------------------------------------------------------
// The GPU version's buffers (shadow/soft_shadow_volumes/soft_shadow_volumes_gpu.cpp).

// Per potential silhouette edge, in the hierarchy's leaf order, 96 bytes: a, b, the third
// vertices w0, w1 (w1 unused with one triangle), the two triangles' planes n_i . x + d_i with
// |n_i| = scale_i (EdgeFacing).
struct SsvEdge {
  vec3 a;        //  0
  uint triangles;  // 12: 1 or 2
  vec3 b;        // 16
  uint pad;      // 28
  vec3 w0;       // 32
  float d0;      // 44
  vec3 w1;       // 48
  float d1;      // 60
  vec3 n0;       // 64
  float scale0;  // 76
  vec3 n1;       // 80
  float scale1;  // 92
};

// Per hierarchy node, 80 bytes: its box, its children (inner: first and first + 1, count 0) or
// edges [first, first + count), and the facing bound (cullable 0: none).
struct SsvNode {
  vec3 lo;              //  0
  uint first;           // 12
  vec3 hi;              // 16
  uint count;           // 28
  vec3 axis;            // 32
  float spread;         // 44
  vec3 centre;          // 48
  float half_diagonal;  // 60
  float h_lo;           // 64
  float h_hi;           // 68
  uint cullable;        // 72
  uint pad;             // 76
};

// The light block: the pyramid's base (4 corners of the samples' padded rectangle, then its
// centre), then the n light samples' points: vec3[5 + n].
PN_CONST uint kSsvLightCorners = 5u;

// The counters the kernel adds to (uint[8]): as the CPU's extra.* (edge tests, edge updates,
// reference crossings, sample groups), then the loop-limit flag, the stack-overflow flag.
PN_CONST uint kSsvEdgeTests = 0u;
PN_CONST uint kSsvEdgeUpdates = 1u;
PN_CONST uint kSsvCrossings = 2u;
PN_CONST uint kSsvGroups = 3u;
PN_CONST uint kSsvLoopCut = 4u;
PN_CONST uint kSsvStackFull = 5u;
PN_CONST uint kSsvCounters = 8u;

// Light samples one work group holds in shared memory (one view sample per group of 64 threads).
PN_CONST uint kSsvMaxSamples = 1024u;
// The hierarchy's walk stack (per view sample): deeper hierarchies are refused on the host.
PN_CONST uint kSsvStack = 64u;

// Push constants, 112 bytes.
struct SsvParams {
  uint64_t scene;        // the GPU scene (gpu/scene_layout_shared.h)
  uint64_t samples;      // GpuViewSample[slots]
  uint64_t visibility;   // float[slots]
  uint64_t nodes;        // SsvNode[]
  uint64_t edges;        // SsvEdge[]
  uint64_t light;        // vec3[5 + n]
  uint64_t counters;     // uint[kSsvCounters]
  uint64_t closed;       // uint per scene object: 1 where its mesh is closed
  vec3 light_center;
  uint n;                // light samples
  vec3 light_n;          // the light's normal: points behind its plane see none of it
  uint slots;
  uint node_count;       // 0: no silhouette edges
  int canary;            // gpu::kLoopLimitCanary
  uint first_sample;     // this dispatch's light samples: [first_sample, first_sample + sample_count)
  uint sample_count;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::SsvEdge) == 96);
static_assert(sizeof(penumbra::shader::SsvNode) == 80);
static_assert(sizeof(penumbra::shader::SsvParams) == 112);
#endif

#endif  // PENUMBRA_SHADOW_SSV_SHARED_H
