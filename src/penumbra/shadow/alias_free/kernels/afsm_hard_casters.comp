#version 460
// afsm-hard on the GPU, sintorn2008 §3.2-3.3 (alias_free.cpp center_shadow, the "casters" phase):
// one thread per input triangle. An opaque-somewhere triangle casts (a closed mesh with its light
// back-facing triangles only, §3.3) with its four planes, and its conservative coverage is set
// up: the triangle clipped to the view (raster_clip), projected to texel space, and the texel
// rows of its bounding box counted for the cover pass (rows[], scanned next). sintorn2008 §3.2
// grew each triangle by half a texel in a geometry shader for the fixed-function rasterizer; here
// the exact texel-square test of raster/conservative.cpp runs in afsm_hard_cover.comp instead.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/conservative_cover.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/shadow/alias_free/alias_free_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmHardParams p; } pc;
layout(buffer_reference, scalar) writeonly buffer CastersOut { AfsmHardCaster v[]; };

void main() {
  uint g = pn_thread_index();
  if (g >= pc.p.count) return;
  Uints rows = Uints(pc.p.rows);
  rows.v[g] = 0u;
  scene_bind(pc.p.scene);
  uint object, prim;
  raster_source(g, object, prim);
  if (!(raster_opacity(object, prim) > 0.0f)) return;
  vec3 p0, p1, p2;
  raster_vertices(object, prim, p0, p1, p2);
  vec3 c = pc.p.light_center;
  vec3 n = cross(p1 - p0, p2 - p0);
  float side = dot(n, c - p0);
  bool closed = (g_objects.v[object].flags & kObjectClosed) != 0u;
  // §3.3: a closed mesh casts with its light back-facing triangles only.
  if (closed ? !(side < 0.0f) : side == 0.0f) return;
  RasterView view = RasterViewRef(pc.p.view).v;
  vec4 poly[kRasterMaxClipVertices];
  poly[0] = raster_project(view, p0);
  poly[1] = raster_project(view, p1);
  poly[2] = raster_project(view, p2);
  uint o0 = raster_outcode(view, poly[0]), o1 = raster_outcode(view, poly[1]), o2 = raster_outcode(view, poly[2]);
  if ((o0 & o1 & o2) != 0u) return;  // wholly outside one plane
  int count = (o0 | o1 | o2) == 0u ? 3 : raster_clip(view, o0 | o1 | o2, poly);
  if (count == 0) return;
  Vec2s polygon = Vec2s(pc.p.polygons);
  float x0 = pn_inf(), x1 = -pn_inf(), y0 = pn_inf(), y1 = -pn_inf();
  for (int k = 0; k < count; ++k) {
    vec2 t = poly[k].xy / poly[k].w;
    if (isinf(t.x) || isnan(t.x) || isinf(t.y) || isnan(t.y)) return;
    polygon.v[g * uint(kRasterMaxClipVertices) + uint(k)] = t;
    x0 = min(x0, t.x);
    x1 = max(x1, t.x);
    y0 = min(y0, t.y);
    y1 = max(y1, t.y);
  }
  int ix0, ix1, iy0, iy1;
  if (!conservative_box(x0, x1, y0, y1, view.width, view.height, kAfsmCoverSlack, ix0, ix1, iy0, iy1)) return;
  AfsmHardCaster k;
  bool front = side > 0.0f;
  k.support = front ? -n : n;
  k.rows = uint(iy1 - iy0);
  k.v0 = p0;
  k.count = uint(count);
  k.e0 = afsm_edge_plane(p0 - c, p1 - p0, front);
  k.x0 = ix0;
  k.e1 = afsm_edge_plane(p1 - c, p2 - p1, front);
  k.x1 = ix1;
  k.e2 = afsm_edge_plane(p2 - c, p0 - p2, front);
  k.y0 = iy0;
  CastersOut(pc.p.casters).v[g] = k;
  rows.v[g] = k.rows;
}
