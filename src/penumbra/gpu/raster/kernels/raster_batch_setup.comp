#version 460
// The batch mode's set-up (gpu/raster/raster_batch_layout_shared.h): one thread per (input
// triangle, view), a triangle's views side by side so they share its vertex reads. The one mode's
// set-up (raster_setup.comp: raster_polygon, the fan, raster_set_up) with the view carried in the
// set-up triangle; optionally, the triangles of closed objects that face away from every point of
// an outline are skipped first (lam.cpp cull_hidden_back_faces: they are never the nearest surface
// seen from the light), and so are the objects the view's own flags skip (per-view caster culling:
// the objects wholly outside its frustum). Counters run on past the capacities, so the host knows
// how much room a second try needs.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_batch_layout_shared.h"
#include "penumbra/gpu/raster/raster_stages.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterBatchSetupParams p; } pc;
layout(buffer_reference, scalar) readonly buffer BatchViews { GpuRasterBatchView v[]; };
layout(buffer_reference, scalar) buffer BatchTriangles { GpuRasterBatchTriangle v[]; };

// Appends one set-up triangle and its work items.
void emit(GpuRasterBatchTriangle t) {
  RasterStateRef state = RasterStateRef(pc.p.state);
  uint index = atomicAdd(state.s.setup_count, 1u);
  if (index >= pc.p.triangle_capacity) return;  // counted: the host grows the buffer and retries
  BatchTriangles(pc.p.triangles).v[index] = t;
  int tx0 = t.t.s.x0 >> kRasterTileShift, tx1 = (t.t.s.x1 - 1) >> kRasterTileShift;
  int ty0 = t.t.s.y0 >> kRasterTileShift, ty1 = (t.t.s.y1 - 1) >> kRasterTileShift;
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

// Whether input triangle g belongs to an oriented (closed) object and faces away from every
// point of the outline.
bool hidden_from_outline(uint g) {
  if (pc.p.orientation == 0UL) return false;
  uint object, prim;
  raster_source(g, object, prim);
  float orient = Floats(pc.p.orientation).v[object];
  if (orient == 0.0f) return false;
  vec3 p0, p1, p2;
  raster_vertices(object, prim, p0, p1, p2);
  vec3 n = cross(p1 - p0, p2 - p0) * orient;
  Vec3s outline = Vec3s(pc.p.outline);
  for (uint i = 0u; i < pc.p.outline_count; ++i)
    if (dot(outline.v[i] - p0, n) >= 0.0f) return false;
  return true;
}

void main() {
  uint thread = pn_thread_index();
  uint g = thread / pc.p.view_count, view_index = thread % pc.p.view_count;
  if (g >= pc.p.triangle_count) return;
  scene_bind(pc.p.scene);
  if (hidden_from_outline(g)) return;
  RasterView view = BatchViews(pc.p.views).v[view_index].view;
  uint object, prim;
  vec2 t[kRasterMaxClipVertices];
  double v[kRasterMaxClipVertices];
  // This view's row of per-object flags: an address into the (view, object) array.
  uint64_t flags = pc.p.view_object_flags == 0UL
                       ? 0UL
                       : pc.p.view_object_flags + uint64_t(4u) * uint64_t(view_index) * uint64_t(pc.p.object_count);
  int n = raster_polygon(view, g, pc.p.culling, pc.p.opaque_only != 0u, flags, object, prim, t, v);
  // A clipped polygon becomes a fan; shared fan edges follow the fill rule like any other.
  for (int k = 1; k + 1 < n; ++k) {
    GpuRasterBatchTriangle r;
    if (!raster_set_up(t[0], t[k], t[k + 1], v[0], v[k], v[k + 1], view.width, view.height, r.t.s)) continue;
    r.t.s.source = g;
    r.t.object = object;
    r.t.prim = prim;
    r.view = view_index;
    r.pad = 0u;
    emit(r);
  }
}
