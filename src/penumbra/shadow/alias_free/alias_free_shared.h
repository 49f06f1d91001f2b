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

// ---- afsm (§4.2): light samples as lines on the light -----------------------------------------

// Sine of the angle under which a listed point must see a caster's plane for the caster to be
// tested against it: below, the cone from the point over the triangle is flat.
PN_CONST float kAfsmFlat = 1e-5f;

// The N light samples lie in one plane: q_i = c + ls u_i.x + lt u_i.y (ls, lt: the light's frame
// vectors times its extent radius), so a plane meets them in a line, sample u_i on its positive
// side when g . u_i + h > 0.

// The exact test of one light sample against a line, written once so that the table, the exact
// masks, the sample grid (sample_masks.h above) and the GPU classify every sample the same way.
PN_INLINE bool afsm_above(float ux, float uy, vec2 g, float h) {
  PN_PRECISE float v = ux * g.x + uy * g.y + h;
  return v > 0.0f;
}

// PlaneMaskLut::side_of_disk: where the line misses the samples' disk (squared radius
// max_distance2, padded): -1 when no sample is on its positive side, +1 when all are, 0 when it
// may cut them.
PN_INLINE int afsm_side_of_disk(vec2 g, float h, float max_distance2) {
  PN_PRECISE float g2 = g.x * g.x + g.y * g.y;
  PN_PRECISE float reach2 = g2 * max_distance2;
  PN_PRECISE float h2 = h * h;
  if (h2 > reach2 || (g2 == 0.0f && h != 0.0f)) return h > 0.0f ? 1 : -1;
  if (g2 == 0.0f) return -1;  // g = 0, h = 0: nothing strictly positive
  return 0;
}

// The plane with normal e through a point x of the sample plane's side as a line: g = (e . ls,
// e . lt), h = e . (c - x) (pair_filter.cpp's order of operations).
PN_INLINE vec2 afsm_line_g(vec3 e, vec3 ls, vec3 lt) {
  PN_PRECISE float gx = e.x * ls.x + e.y * ls.y + e.z * ls.z;
  PN_PRECISE float gy = e.x * lt.x + e.y * lt.y + e.z * lt.z;
  return vec2(gx, gy);
}
PN_INLINE float afsm_line_h(vec3 e, vec3 cx) {
  PN_PRECISE float h = e.x * cx.x + e.y * cx.y + e.z * cx.z;
  return h;
}

// The four lines of a (listed point p, caster) pair (§4.2, Fig. 6): the light samples behind the
// caster's supporting plane as seen from p (gb, hb), and inside the three planes through p and an
// edge (g0..g2, h0..h2). A light sample is hidden by the whole triangle when it is above all four
// (afsm_above).
struct AfsmPairLines {
  vec2 g0;
  float h0;
  vec2 g1;
  float h1;
  vec2 g2;
  float h2;
  vec2 gb;
  float hb;
};

// The pair's lines (pair_filter.cpp filter_pairs, scalar): false when the caster hides nothing
// from p: p behind a closed caster (a closed mesh blocks a light sample only with the triangles
// facing away from it, §3.3 per light sample), in an open caster's plane, or seeing it at an
// angle whose sine is below kFlat (flat_scale = kFlat^2 |normal|^2: its edge planes would be
// rounding noise). normal = cross(v1 - v0, v2 - v0).
PN_INLINE bool afsm_pair_lines(vec3 p, vec3 v0, vec3 v1, vec3 v2, vec3 normal, float flat_scale, bool closed, vec3 c,
                               vec3 ls, vec3 lt, PN_OUT(AfsmPairLines) lines) {
  vec3 t = p - v0;
  PN_PRECISE float side = normal.x * t.x + normal.y * t.y + normal.z * t.z;
  PN_PRECISE float flat2 = flat_scale * (t.x * t.x + t.y * t.y + t.z * t.z);
  if (closed ? !(side > 0.0f) : side == 0.0f) return false;
  PN_PRECISE float side2 = side * side;
  if (!(side2 > flat2)) return false;
  bool front = side > 0.0f;
  vec3 cp = c - p;
  vec3 e0 = afsm_edge_plane(v0 - p, v1 - v0, front);
  vec3 e1 = afsm_edge_plane(v1 - p, v2 - v1, front);
  vec3 e2 = afsm_edge_plane(v2 - p, v0 - v2, front);
  lines.g0 = afsm_line_g(e0, ls, lt);
  lines.h0 = afsm_line_h(e0, cp);
  lines.g1 = afsm_line_g(e1, ls, lt);
  lines.h1 = afsm_line_h(e1, cp);
  lines.g2 = afsm_line_g(e2, ls, lt);
  lines.h2 = afsm_line_h(e2, cp);
  // Behind the supporting plane as seen from p: the side away from p.
  float sign = front ? -1.0f : 1.0f;
  vec2 sg = afsm_line_g(normal, ls, lt);
  lines.gb = vec2(sg.x * sign, sg.y * sign);
  lines.hb = afsm_line_h(normal, c - v0) * sign;
  return true;
}

// ---- the plane-mask table (§4.2, PlaneMaskLut in sample_masks.h) -------------------------------

// A monotone stand-in for atan2 on [0, 4) (the "diamond angle"): cheaper than atan2, and the
// table's angle bins are uniform in it.
PN_INLINE float afsm_diamond_angle(float x, float y) {
  if (y >= 0.0f) return x >= 0.0f ? y / (x + y) : 1.0f - x / (-x + y);
  return x < 0.0f ? 2.0f - y / (-x - y) : 3.0f + x / (x - y);
}

PN_CONST int kAfsmLutNone = -1;  // the line misses the samples' disk: no sample above it
PN_CONST int kAfsmLutAll = -2;   // every sample above it

// The table cell of the line g . u + h = 0 (PlaneMaskLut::lookup): a * distance_bins + b over
// angle_bins x distance_bins cells of (diamond angle of g, signed distance -h / |g| in
// [-max_distance, max_distance)), or kAfsmLutNone / kAfsmLutAll. The cell's sure bits are above
// every line of the cell, its unsure ones are tested exactly (afsm_above): its bits are the exact
// test's, whatever cell a rounding picks next to the right one (the table's margin).
PN_INLINE int afsm_lut_cell(vec2 g, float h, float max_distance, int angle_bins, int distance_bins) {
  float len = sqrt(g.x * g.x + g.y * g.y);
  float d = len > 0.0f ? -h / len : (h > 0.0f ? -max_distance * 4.0f : max_distance * 4.0f);
  if (!(d < max_distance)) return kAfsmLutNone;
  if (d <= -max_distance) return kAfsmLutAll;
  int a = min(int(afsm_diamond_angle(g.x, g.y) * (float(angle_bins) * 0.25f)), angle_bins - 1);
  int b = int(clamp(float(int((d + max_distance) * (float(distance_bins) / (2.0f * max_distance)))), 0.0f,
                    float(distance_bins - 1)));
  return a * distance_bins + b;
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

// A list position, 16 bytes: bytes 0-11 the listed point, 12-15 its shadow: 0 (lit),
// kAfsmCenterPartial where only casters that stop part of the light (semi-transparent, alpha
// blend) cover it and its ray to the centre decides, kAfsmCenterBlocked where a caster blocks it
// (alias_free.cpp center_shadow: the same values, ordered so that the larger mark wins).
PN_CONST uint kAfsmCenterPartial = 1u;
PN_CONST uint kAfsmCenterBlocked = 2u;
struct AfsmListed {
  vec3 p;
  uint shadow;
};

// What the cover kernels count (kept on the device, read once the frame has run), 16 bytes, after
// the view's RasterView in its buffer (bytes 160-175): (covered texel, caster) visits and (list
// entry, caster) tests.
struct AfsmCounters {
  uint64_t texel_visits;
  uint64_t sample_tests;
};

// What the kernels read and write, 128 bytes (the push constants of every afsm-hard kernel).
//   scene     SceneDesc               view      RasterView of the fitted light view, then AfsmCounters
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

// ---- the GPU `afsm` (alias_free_gpu.cpp) -------------------------------------------------------

// The light as afsm's kernels read it, 96 bytes, then its samples and table (uploaded per frame):
//   bytes  0-11 c (centre), 12-15 n (light samples, <= 1024)
//   bytes 16-27 ls,         28-31 words (uint words of a mask: (n + 31) / 32)
//   bytes 32-43 lt,         44-47 max_distance2 (PlaneMaskLut::max_distance2)
//   bytes 48-59 axis (the view's forward), 60-63 stride: the uints of a list position's masks,
//               `words` (its light samples blocked), or 2 words where the scene has casters that
//               stop only part of the light (then the samples they cover follow: the rays decide)
//   bytes 64-79 lo.x lo.y hi.x hi.y: the bounding box of the samples' local coordinates
//   bytes 80-83 max_distance (PlaneMaskLut::max_distance), 84-87 angle_bins, 88-91 distance_bins
//               (0: no table, every light sample tested exactly: lut=false), 92-95 pad
//   then vec2 local[n] (u_i), then vec3 points[n] (the world points, LightSamples::points), then
//   the table: PlaneMaskLut::cells() (per cell (n + 63) / 64 uint64 sure bits, as many unsure)
struct AfsmSoftLight {
  vec3 c;
  uint n;
  vec3 ls;
  uint words;
  vec3 lt;
  float max_distance2;
  vec3 axis;
  uint stride;
  float lo_x;
  float lo_y;
  float hi_x;
  float hi_y;
  float max_distance;
  uint angle_bins;
  uint distance_bins;
  uint pad;
};

// One caster of afsm_soft_casters.comp, 80 bytes, per input triangle:
//   bytes  0-11 v0, 12-15 rows (texel rows of its influence region's bounding box; 0: none)
//   bytes 16-27 v1, 28-31 x0     32-43 v2, 44-47 x1     48-59 normal, 60-63 y0
//   bytes 64-67 count (vertices of its region's hull, at triangle * 12 of the polygons buffer),
//   68-79 pad
struct AfsmSoftCaster {
  vec3 v0;
  uint rows;
  vec3 v1;
  int x0;
  vec3 v2;
  int x1;
  vec3 normal;
  int y0;
  uint count;
  uint pad0;
  uint pad1;
  uint pad2;
};

// The most vertices of an influence region's hull (gpu/raster/conservative_cover.glsl
// kConservativeHullPoints: the light samples' bounding rectangle through three vertices).
PN_CONST uint kAfsmRegionVertices = 12u;

// A list entry of afsm: its point and the bits of its mask that are preset and not counted (the
// other side's light samples of a split sample), 16 bytes. Its mask: words uints at
// masks + position * words * 4.
struct AfsmSoftListed {
  vec3 p;
  uint ignored;
};

// afsm's depth slabs (the CPU's split_by_depth, texel_lists.h): the list entries cut into up to
// kAfsmMaxSlabs slabs of about equal count by depth from the light, each slab's influence regions
// ending at its own farthest entry (sintorn2008 §4.3's far plane, per slab: smaller regions, the
// same masks). The slabs are cut at the bins of a histogram of the entries' depths, kAfsmDepthBins
// bins uniform in log depth over the fitted view's [near, far] (afsm_depth_bin).
PN_CONST uint kAfsmMaxSlabs = 64u;
PN_CONST uint kAfsmDepthBins = 1024u;

// The slabs' record, 5400 bytes, after the AfsmCounters in the view's buffer (bytes 176-5575):
//   bytes  0-11 the cover pass's indirect dispatch (x, y, z groups; afsm_soft_cover_args),
//          12-15 pad, 16-23 cover_rows (covered rows over the slabs: a counter, as AfsmCounters)
//   bytes 24-279 far_bits: per slab the bits of its farthest listed depth (afsm_soft_list_key)
//   bytes 280-1303 box: per slab the texels holding its lists (afsm_soft_slab_bounds), 4 uints:
//          ~x_min, ~y_min, x_max + 1, y_max + 1 (raised by atomicMax from 0: 0 0 0 0 is empty)
//   then uint slab_of_bin[kAfsmDepthBins]: the bin's entries (afsm_soft_list_count), then the
//   bin's slab (afsm_soft_slabs). From far_bits on it is cleared each frame.
struct AfsmSlabs {
  uint cover_groups_x;
  uint cover_groups_y;
  uint cover_groups_z;
  uint pad;
  uint64_t cover_rows;
  uint far_bits[kAfsmMaxSlabs];
  uint box[4u * kAfsmMaxSlabs];
  uint slab_of_bin[kAfsmDepthBins];
};

// What afsm's kernels read and write, 128 bytes.
//   light     AfsmSoftLight + samples  state  uint[2 slots]: per entry (front, back) of a slot: its
//             texel, its key (slab × texels + texel), then its list position, or a kAfsm* code
//   points    vec3[2 slots]            masks  uint[capacity * words]
//   first     uint[slabs × texels + 1]: counts per key, then (scan) each key's first position
//   casters   AfsmSoftCaster[triangles], rows uint[triangles + 1], polygons vec2[12 triangles]:
//             one slab's at a time (slab: the one the casters and cover kernels run for)
//   others as AfsmHardParams
struct AfsmSoftParams {
  uint64_t scene;
  uint64_t view;
  uint64_t samples;
  uint64_t visibility;
  uint64_t light;
  uint64_t state;
  uint64_t points;
  uint64_t first;
  uint64_t cursor;
  uint64_t listed;
  uint64_t masks;
  uint64_t casters;
  uint64_t rows;
  uint64_t polygons;
  uint count;
  uint triangles;
  uint slab;
  uint slabs;
};

PN_SHARED_END

#endif  // PENUMBRA_SHADOW_ALIAS_FREE_ALIAS_FREE_SHARED_H
