#version 460
// afsm-hard on the GPU, sintorn2008 §3.2-3.3 (alias_free.cpp center_shadow, "raster_center"):
// one thread per (caster, texel row of its bounding box), found by a binary search in the scanned
// row counts (gpu/segments.glsl). The row's covered texels are those whose closed square meets the caster's polygon
// (gpu/raster/conservative_cover.glsl, the CPU's test of raster/conservative.cpp), grown by
// kAfsmCoverSlack; every view sample listed there is tested against the caster's four
// planes (afsm_hard_blocks) and, on an alpha-textured caster, against its mask where the segment
// to the light's centre crosses it. A caster that stops only part of the light marks the sample
// partial (its ray decides: afsm_hard_resolve); a blocking one marks it blocked (atomicMax: the
// larger mark wins, blocked > partial). A sample's mark skips the casters that cannot raise it.
// sintorn2008 ran this per fragment of the hardware rasterizer; the row threads are its compute
// form.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/conservative_cover.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/gpu/segments.glsl"
#include "penumbra/shadow/alias_free/alias_free_shared.h"
#include "penumbra/shadow/alias_free/kernels/afsm_counters.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmHardParams p; } pc;
layout(buffer_reference, scalar) readonly buffer CastersIn { AfsmHardCaster v[]; };
layout(buffer_reference, scalar) buffer ListedRef { AfsmListed v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.count) return;
  Uints rows = Uints(pc.p.rows);
  // The caster whose rows [rows[g], rows[g + 1]) hold i.
  uint g = segment_of(rows, pc.p.triangles, i);
  AfsmHardCaster k = CastersIn(pc.p.casters).v[g];
  int y = k.y0 + int(i - rows.v[g]);
  RasterView view = RasterViewRef(pc.p.view).v;
  int x_lo, x_hi;
  if (!conservative_row_span(Vec2s(pc.p.polygons), g * uint(kRasterMaxClipVertices), int(k.count), y, k.x0, k.x1,
                             kAfsmCoverSlack, x_lo, x_hi))
    return;
  scene_bind(pc.p.scene);
  vec3 c = pc.p.light_center;
  Uints first = Uints(pc.p.first);
  ListedRef listed = ListedRef(pc.p.listed);
  uint object, prim;
  raster_source(g, object, prim);
  bool textured = raster_textured(object);
  uint mark = raster_semi_transparent(object, prim) ? kAfsmCenterPartial : kAfsmCenterBlocked;
  // The lists are stored texel by texel in row-major order: the samples of the span's texels are
  // one range of positions.
  uint row = uint(y) * uint(view.width);
  uint end = first.v[row + uint(x_hi + 1)];
  uint tests = 0u;
  for (uint pos = first.v[row + uint(x_lo)]; pos < end; ++pos) {
    AfsmListed l = listed.v[pos];
    if (l.shadow >= mark) continue;
    ++tests;
    if (!afsm_hard_blocks(k.support, k.v0, k.e0, k.e1, k.e2, c, l.p)) continue;
    if (textured && mark == kAfsmCenterBlocked) {
      // RasterTriangle::opacity_on_line: the mask where the line p + s (p - c) meets the caster.
      vec3 p0, p1, p2;
      raster_vertices(object, prim, p0, p1, p2);
      float b1, b2, s;
      if (!triangle_line_crossing(p0, p1, p2, l.p, l.p - c, b1, b2, s)) {
        b1 = 0.0f;
        b2 = 0.0f;
      }
      float a = object_mirrored(object) ? surface_opacity(object, prim, b2, b1) : surface_opacity(object, prim, b1, b2);
      if (!(a > 0.0f)) continue;
    }
    atomicMax(listed.v[pos].shadow, mark);
  }
  afsm_count(pc.p.view, uint(x_hi - x_lo + 1), tests);
}
