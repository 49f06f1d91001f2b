#version 460
// The GPU rasterizer's set-up (gpu/raster/raster_layout_shared.h; rasterizer.cpp
// set_up_triangles): one thread per input triangle. Triangles with opacity <= 0 cast nothing;
// the filter culls by facing and semi-transparency, a mode's per-object flags leave objects out
// or cull them to their front faces; the rest are transformed to homogeneous texel
// space, clipped against near, far and the guard band (Sutherland-Hodgman), fanned, and each fan
// triangle set up (raster/raster_shared.h raster_set_up, in double) and appended with one work
// item per 16 x 16-texel tile of its texel box. Counters run on past the capacities, so the host
// knows how much room a second try needs.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterSetupParams p; } pc;

// Appends one set-up triangle and its work items.
void emit(GpuRasterTriangle t) {
  RasterStateRef state = RasterStateRef(pc.p.state);
  uint index = atomicAdd(state.s.setup_count, 1u);
  if (index >= pc.p.triangle_capacity) return;  // counted: the host grows the buffer and retries
  RasterTriangles(pc.p.triangles).v[index] = t;
  int tx0 = t.s.x0 >> kRasterTileShift, tx1 = (t.s.x1 - 1) >> kRasterTileShift;
  int ty0 = t.s.y0 >> kRasterTileShift, ty1 = (t.s.y1 - 1) >> kRasterTileShift;
  uint cols = uint(tx1 - tx0 + 1);
  uint count = cols * uint(ty1 - ty0 + 1);
  uint64_t first = atomicAdd(state.s.item_count, uint64_t(count));
  if (first + uint64_t(count) > uint64_t(pc.p.item_capacity)) return;
  RasterItems items = RasterItems(pc.p.items);
  for (uint k = 0u; k < count; ++k) {
    GpuRasterItem item;
    item.triangle = index;
    item.tile = uint(tx0 + int(k % cols)) | (uint(ty0 + int(k / cols)) << 16);
    items.v[uint(first) + k] = item;
  }
}

void main() {
  uint g = pn_thread_index();
  if (g >= pc.p.triangle_count) return;
  scene_bind(pc.p.scene);
  RasterView view = RasterViewRef(pc.p.view).v;
  uint object, prim;
  raster_source(g, object, prim);
  if (!(raster_opacity(object, prim) > 0.0f)) return;
  if (pc.p.opaque_only != 0u && raster_semi_transparent(object, prim)) return;
  uint culling = pc.p.culling;
  if (pc.p.object_flags != 0UL) {  // a mode's per-object choices
    uint flags = Uints(pc.p.object_flags).v[object];
    if ((flags & kRasterObjectSkip) != 0u) return;
    if ((flags & kRasterObjectFrontOnly) != 0u) culling = 1u;
  }
  vec3 p0, p1, p2;
  raster_vertices(object, prim, p0, p1, p2);
  if (culling != 0u) {
    // clipping.h faces_light: the light sees the side cross(p1 - p0, p2 - p0) points to.
    vec3 n = cross(p1 - p0, p2 - p0);
    bool front = view.perspective != 0u ? dot(n, view.eye - p0) > 0.0f : dot(n, view.forward) < 0.0f;
    if (front != (culling == 1u)) return;
  }
  vec4 poly[kRasterMaxClipVertices];
  poly[0] = raster_project(view, p0);
  poly[1] = raster_project(view, p1);
  poly[2] = raster_project(view, p2);
  uint any = 0u, all = 0x3fu;
  for (int k = 0; k < 3; ++k) {
    uint code = raster_outcode(view, poly[k]);
    any |= code;
    all &= code;
  }
  if (all != 0u) return;  // every vertex outside one plane
  int n = any == 0u ? 3 : raster_clip(view, any, poly);
  if (n == 0) return;
  bool perspective = view.perspective != 0u;
  vec2 t[kRasterMaxClipVertices];
  double v[kRasterMaxClipVertices];
  for (int k = 0; k < n; ++k) {
    precise float x = poly[k].x / poly[k].w;
    precise float y = poly[k].y / poly[k].w;
    t[k] = vec2(x, y);
    precise double d = perspective ? 1.0LF / double(poly[k].w) : double(poly[k].z);
    v[k] = d;
  }
  // A clipped polygon becomes a fan; shared fan edges follow the fill rule like any other.
  for (int k = 1; k + 1 < n; ++k) {
    GpuRasterTriangle r;
    if (!raster_set_up(t[0], t[k], t[k + 1], v[0], v[k], v[k + 1], view.width, view.height, r.s)) continue;
    r.s.source = g;
    r.object = object;
    r.prim = prim;
    emit(r);
  }
}
