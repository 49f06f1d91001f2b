#version 460
// afsm-hard on the GPU, sintorn2008 §3.2-3.3 (alias_free.cpp center_shadow, "raster_center"):
// one thread per (caster, texel row of its bounding box), found by a binary search in the scanned
// row counts. The row's covered texels are those whose closed square meets the caster's polygon
// (raster/conservative.cpp cover: per polygon edge, the square's corner farthest inside it),
// grown by kAfsmCoverSlack; every view sample listed there is tested against the caster's four
// planes (afsm_hard_blocks) and, on an alpha-textured caster, against its mask where the segment
// to the light's centre crosses it. A set shadow bit skips further tests. sintorn2008 ran this
// per fragment of the hardware rasterizer; the row threads are its compute form.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/shadow/alias_free/alias_free_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmHardParams p; } pc;
layout(buffer_reference, scalar) readonly buffer CastersIn { AfsmHardCaster v[]; };
layout(buffer_reference, scalar) buffer ListedRef { AfsmListed v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.count) return;
  Uints rows = Uints(pc.p.rows);
  // The caster g whose rows [rows[g], rows[g + 1]) hold i: upper_bound over rows[1 .. triangles].
  uint lo = 0u, n = pc.p.triangles;
  while (n > 0u) {
    uint step = n / 2u;
    uint it = lo + step;
    if (rows.v[it + 1u] <= i) {
      lo = it + 1u;
      n -= step + 1u;
    } else {
      n = step;
    }
  }
  uint g = lo;
  AfsmHardCaster k = CastersIn(pc.p.casters).v[g];
  int y = k.y0 + int(i - rows.v[g]);
  RasterView view = RasterViewRef(pc.p.view).v;
  Vec2s polygon = Vec2s(pc.p.polygons);
  uint base = g * uint(kRasterMaxClipVertices);
  int count = int(k.count);
  float area = 0.0f;
  for (int e = 0; e < count; ++e) {
    vec2 a = polygon.v[base + uint(e)], b = polygon.v[base + uint((e + 1) % count)];
    area += a.x * b.y - a.y * b.x;
  }
  float sgn = area < 0.0f ? -1.0f : 1.0f;
  float x_lo = float(k.x0), x_hi = float(k.x1 - 1);
  for (int e = 0; e < count && x_lo <= x_hi; ++e) {
    vec2 a = polygon.v[base + uint(e)], b = polygon.v[base + uint((e + 1) % count)];
    float nx = -sgn * (b.y - a.y), ny = sgn * (b.x - a.x);
    // Column x is inside this edge when nx x + K >= 0 (the best corner, relative to a).
    float K = ny * (float(y) + (ny > 0.0f ? 1.0f : 0.0f) - a.y) + nx * ((nx > 0.0f ? 1.0f : 0.0f) - a.x) +
              kAfsmCoverSlack * (abs(nx) + abs(ny));
    if (nx > 0.0f) x_lo = max(x_lo, ceil(-K / nx));
    else if (nx < 0.0f) x_hi = min(x_hi, floor(K / -nx));
    else if (K < 0.0f) x_hi = x_lo - 1.0f;
  }
  if (x_lo > x_hi) return;
  scene_bind(pc.p.scene);
  vec3 c = pc.p.light_center;
  Uints first = Uints(pc.p.first);
  ListedRef listed = ListedRef(pc.p.listed);
  uint object, prim;
  raster_source(g, object, prim);
  bool textured = raster_textured(object);
  for (int x = int(x_lo); x <= int(x_hi); ++x) {
    uint texel = uint(y) * uint(view.width) + uint(x);
    uint end = first.v[texel + 1u];
    for (uint pos = first.v[texel]; pos < end; ++pos) {
      AfsmListed l = listed.v[pos];
      if (l.shadow != 0u) continue;
      if (!afsm_hard_blocks(k.support, k.v0, k.e0, k.e1, k.e2, c, l.p)) continue;
      if (textured) {
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
      listed.v[pos].shadow = 1u;
    }
  }
}
