// What `afsm-hard` computes per (listed view sample, caster) on both devices (alias_free.cpp on
// the CPU, alias_free_gpu.cpp + kernels/afsm_*.comp on the GPU), and the GPU version's buffers and
// kernel parameters, byte by byte. Common subset of C++ and GLSL (core/shader_compat.h), scalar
// block layout.
#ifndef PENUMBRA_SHADOW_ALIAS_FREE_ALIAS_FREE_SHARED_H
#define PENUMBRA_SHADOW_ALIAS_FREE_ALIAS_FREE_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// The plane through an apex x (the light's centre, a view sample) and the triangle edge from v_i
// to v_i + d (d = v_{i+1} - v_i, the triangle wound v_0 v_1 v_2), as its normal, pointing into the
// cone from x over the triangle. a = v_i - x. The orientation needs no test against the third
// vertex: det[a, d, v_{i+2} - v_i] = -dot(n, x - v_i) for every edge (n = the winding normal), so
// it follows from the apex's side of the triangle alone, the same for all three edges even where
// x sees the triangle almost edge-on (where a per-edge test of the third vertex is rounding
// noise). Using the exact edge vector d rather than (v_{i+1} - x) keeps the plane accurate for
// small, distant triangles.
PN_INLINE vec3 afsm_edge_plane(vec3 a, vec3 d, bool apex_in_front) { return apex_in_front ? cross(d, a) : cross(a, d); }

// sintorn2008 §3.3: point p is in the caster's hard shadow from the light point c when it lies
// behind the caster's supporting plane (support, oriented away from c, through v0) and inside the
// three planes through c and an edge (e0, e1, e2 from afsm_edge_plane, apex c).
PN_INLINE bool afsm_hard_blocks(vec3 support, vec3 v0, vec3 e0, vec3 e1, vec3 e2, vec3 c, vec3 p) {
  if (!(dot(support, p - v0) > 0.0f)) return false;
  vec3 d = p - c;
  return dot(e0, d) >= 0.0f && dot(e1, d) >= 0.0f && dot(e2, d) >= 0.0f;
}

// ---- the GPU version (alias_free_gpu.cpp) ------------------------------------------------------

// A view-sample slot's state after listing (uint per slot of the frame): its list position once
// scattered (before: its texel), or one of these codes.
PN_CONST uint kAfsmMiss = 0xffffffffu;       // the camera ray hit nothing: V untouched
PN_CONST uint kAfsmNotListed = 0xfffffffeu;  // behind the light, or light back-facing on a closed mesh: V = 0
PN_CONST uint kAfsmUncovered = 0xfffffffdu;  // outside the fitted view (or before its near plane): V = 1

// How far (texels) the GPU's conservative coverage grows a caster's polygon against float
// rounding (the CPU's, in double, grows it by 1e-5): extra texels cost tests, never results.
PN_CONST float kAfsmCoverSlack = 0.01f;

// One caster of afsm_hard_casters.comp, 80 bytes, per input triangle (gather_raster_triangles'
// numbering):
//   bytes  0-11 support, 12-15 rows (texel rows its polygon's bounding box spans; 0: casts nothing)
//   bytes 16-27 v0,      28-31 count (vertices of its clipped polygon, 3-9)
//   bytes 32-43 e0,      44-47 x0 (the bounding box, texels [x0, x1) x [y0, y0 + rows))
//   bytes 48-59 e1,      60-63 x1
//   bytes 64-75 e2,      76-79 y0
// Its polygon in texel space (the triangle clipped to the view's near and far planes and guard
// band, projected): vec2 [kRasterMaxClipVertices] at triangle * 9 of the polygons buffer.
struct AfsmHardCaster {
  vec3 support;
  uint rows;
  vec3 v0;
  uint count;
  vec3 e0;
  int x0;
  vec3 e1;
  int x1;
  vec3 e2;
  int y0;
};

// A list position, 16 bytes: bytes 0-11 the listed point, 12-15 its shadow bit (0 or 1).
struct AfsmListed {
  vec3 p;
  uint shadow;
};

// What the kernels read and write, 128 bytes (the push constants of every afsm-hard kernel).
//   scene     SceneDesc               view      RasterView of the fitted light view
//   samples   GpuViewSample[slots]    visibility float[slots]
//   state     uint[slots]: texel, then list position, or a kAfsm* code
//   points    vec3[slots]: the point each slot is listed at (its shadow ray's origin)
//   first     uint[texels + 1]: counts, then (scan) each texel's first list position; [texels] the total
//   cursor    uint[texels]: scatter cursors
//   listed    AfsmListed[capacity]: per list position
//   casters   AfsmHardCaster[triangles] then (scan) rows: uint[triangles + 1], polygons vec2[9 triangles]
struct AfsmHardParams {
  uint64_t scene;
  uint64_t view;
  uint64_t samples;
  uint64_t visibility;
  uint64_t state;
  uint64_t points;
  uint64_t first;
  uint64_t cursor;
  uint64_t listed;
  uint64_t casters;
  uint64_t rows;
  uint64_t polygons;
  vec3 light_center;
  uint count;  // threads of the dispatch: slots, triangles or (cover) covered texel rows
  vec3 light_n;
  uint triangles;  // input triangles (gather_raster_triangles' count)
};

PN_SHARED_END

#endif  // PENUMBRA_SHADOW_ALIAS_FREE_ALIAS_FREE_SHARED_H
