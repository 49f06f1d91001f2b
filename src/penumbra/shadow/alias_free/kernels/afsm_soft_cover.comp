#version 460
// afsm on the GPU, sintorn2008 §4.2, Fig. 6 (alias_free.cpp AliasFreeSoft::evaluate, "raster"):
// one thread per (caster, texel row of its influence region's hull, conservatively covered), found by a binary search in the
// scanned row counts, for one depth slab (pc.p.slab; dispatched indirectly for the slab's rows,
// afsm_soft_cover_args). For every entry of the slab listed in the row's texels, the pair's four lines on the
// light (alias_free_shared.h afsm_pair_lines: the CPU's filter_pairs) and their masks, 32 light
// samples a word: from the plane-mask table (§4.2: sure bits, the cell's unsure samples tested by
// afsm_above; lut=false: every sample tested; the same bits), ANDed; an alpha-textured caster
// keeps the samples whose segment crosses it inside its mask. The bits OR into the entry's mask
// (atomicOr: several casters cover one texel at once); a caster that stops only part of the light
// (semi-transparent, alpha blend) ORs them into the entry's second mask instead, of the samples
// whose rays decide (afsm_soft_resolve; alias_free.cpp `partial`). sintorn2008 ran this per
// fragment of the hardware rasterizer; a thread per covered row is its compute form.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/conservative_cover.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/gpu/segments.glsl"
#include "penumbra/shadow/alias_free/kernels/afsm_counters.glsl"
#include "penumbra/shadow/alias_free/kernels/afsm_soft_access.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmSoftParams p; } pc;
layout(buffer_reference, scalar) readonly buffer CastersIn { AfsmSoftCaster v[]; };

void main() {
  uint i = pn_thread_index();
  Uints rows = Uints(pc.p.rows);
  if (i >= rows.v[pc.p.triangles]) return;
  uint g = segment_of(rows, pc.p.triangles, i);
  AfsmSoftCaster k = CastersIn(pc.p.casters).v[g];
  int y = k.y0 + int(i - rows.v[g]);
  scene_bind(pc.p.scene);
  uint object, prim;
  raster_source(g, object, prim);
  bool closed = (g_objects.v[object].flags & kObjectClosed) != 0u;
  bool textured = raster_textured(object);
  bool mirrored = object_mirrored(object);
  float len = sqrt(dot(k.normal, k.normal));
  float flat_scale = kAfsmFlat * kAfsmFlat * len * len;
  AfsmSoftLight light = AfsmLightRef(pc.p.light).l;
  bool partial = light.stride > light.words && raster_semi_transparent(object, prim);
  RasterView view = RasterViewRef(pc.p.view).v;
  Uints first = Uints(pc.p.first);
  Uints masks = Uints(pc.p.masks);
  AfsmListedRef listed = AfsmListedRef(pc.p.listed);
  // The lists are stored slab by slab, texel by texel in row-major order: the slab's entries of
  // texels [x0, x1) of row y are one range of positions (and an empty range costs nothing: §4.3's
  // empty lists).
  int x_lo, x_hi;
  if (!conservative_row_span(Vec2s(pc.p.polygons), g * uint(kConservativeHullPoints), int(k.count), y, k.x0, k.x1,
                             kAfsmCoverSlack, x_lo, x_hi))
    return;
  uint row = pc.p.slab * uint(view.width) * uint(view.height) + uint(y) * uint(view.width);
  uint end = first.v[row + uint(x_hi + 1)];
  uint tests = 0u;
  for (uint pos = first.v[row + uint(x_lo)]; pos < end; ++pos) {
    // An entry whose every light sample is already blocked is settled: no caster adds a bit (the
    // CPU's `settled` slots). Not counted as a test, as on the CPU.
    bool settled = true;
    for (uint w = 0u; w < light.words && settled; ++w) {
      uint valid = 32u * (w + 1u) <= light.n ? 0xffffffffu : (1u << (light.n - 32u * w)) - 1u;
      settled = masks.v[pos * light.stride + w] == valid;
    }
    if (settled) continue;
    vec3 p = listed.v[pos].p;
    ++tests;
    AfsmPairLines l;
    if (!afsm_pair_lines(p, k.v0, k.v1, k.v2, k.normal, flat_scale, closed, light.c, light.ls, light.lt, l))
      continue;
    // A line with no light sample on its positive side: the caster hides none (the CPU's
    // early outs, PlaneMaskLut::side_of_disk).
    if (afsm_side_of_disk(l.gb, l.hb, light.max_distance2) < 0 || afsm_side_of_disk(l.g0, l.h0, light.max_distance2) < 0 ||
        afsm_side_of_disk(l.g1, l.h1, light.max_distance2) < 0 || afsm_side_of_disk(l.g2, l.h2, light.max_distance2) < 0)
      continue;
    // §4.2, Fig. 6: the light samples behind the caster AND inside the three edge planes, each
    // line's mask from its table cell (found once per pair); an edge line with the whole light
    // inside it masks nothing out.
    int cb = afsm_cell(light, l.gb, l.hb);
    int c0 = afsm_side_of_disk(l.g0, l.h0, light.max_distance2) > 0 ? kAfsmLutAll : afsm_cell(light, l.g0, l.h0);
    int c1 = afsm_side_of_disk(l.g1, l.h1, light.max_distance2) > 0 ? kAfsmLutAll : afsm_cell(light, l.g1, l.h1);
    int c2 = afsm_side_of_disk(l.g2, l.h2, light.max_distance2) > 0 ? kAfsmLutAll : afsm_cell(light, l.g2, l.h2);
    uint target = pos * light.stride + (partial ? light.words : 0u);
    for (uint w = 0u; w < light.words; ++w) {
      uint have = masks.v[pos * light.stride + w];
      if (partial) have |= masks.v[target + w];
      uint bits = afsm_mask_word(pc.p.light, light, cb, l.gb, l.hb, w) & ~have;
      if (bits != 0u) bits &= afsm_mask_word(pc.p.light, light, c0, l.g0, l.h0, w);
      if (bits != 0u) bits &= afsm_mask_word(pc.p.light, light, c1, l.g1, l.h1, w);
      if (bits != 0u) bits &= afsm_mask_word(pc.p.light, light, c2, l.g2, l.h2, w);
      if (bits != 0u && textured && !partial) {
        // The samples the whole triangle hides whose segment from p meets it in a hole of its
        // mask are not hidden (RasterTriangle::opacity_on_line toward AliasFreeSoft::light_point).
        for (uint rest = bits; rest != 0u; rest &= rest - 1u) {
          uint b = uint(findLSB(rest));
          vec2 u = afsm_local(pc.p.light, 32u * w + b);
          vec3 q = light.c + light.ls * u.x + light.lt * u.y;
          float b1, b2, t;
          if (!triangle_line_crossing(k.v0, k.v1, k.v2, p, q - p, b1, b2, t)) {
            b1 = 0.0f;
            b2 = 0.0f;
          }
          float a = mirrored ? surface_opacity(object, prim, b2, b1) : surface_opacity(object, prim, b1, b2);
          if (!(a > 0.0f)) bits &= ~(1u << b);
        }
      }
      if (bits != 0u) atomicOr(masks.v[target + w], bits);
    }
  }
  afsm_count(pc.p.view, uint(x_hi - x_lo + 1), tests);
}
