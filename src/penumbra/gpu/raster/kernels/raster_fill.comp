#version 460
// The GPU rasterizer's fill (gpu/raster/raster_layout_shared.h; rasterizer.cpp depth_map): one
// thread per work item, a set-up triangle and one 16 x 16-texel tile. Every texel centre of the
// tile the triangle covers (exact int64 edge functions, stepped by addition; top-left rule) is a
// fragment at the depth plane's linear depth (summed as the CPU's scan sums it); an
// alpha-textured triangle is looked up where the ray through the centre meets it, and a mask's
// holes drop the fragment. The fragment's key (ordered z bits << 32 | input index) goes into the
// texel by atomicMin: the nearest surface, ties to the first triangle in input order, as the CPU's
// strict depth test in input order keeps.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterFillParams p; } pc;

void main() {
  uint i = pn_thread_index();
  RasterStateRef state = RasterStateRef(pc.p.state);
  // raster_fill_args dispatched nothing past the items written (none after an overflow).
  uint items = uint(min(state.s.item_count, uint64_t(pc.p.item_capacity)));
  uint fragments = 0u;
  if (i < items) {
    scene_bind(pc.p.scene);
    RasterView view = RasterViewRef(pc.p.view).v;
    GpuRasterItem item = RasterItems(pc.p.items).v[i];
    GpuRasterTriangle tri = RasterTriangles(pc.p.triangles).v[item.triangle];
    RasterSetup t = tri.s;
    int tx = int(item.tile & 0xffffu) << kRasterTileShift, ty = int(item.tile >> 16) << kRasterTileShift;
    int x0 = max(t.x0, tx), x1 = min(t.x1, tx + kRasterTile);
    int y0 = max(t.y0, ty), y1 = min(t.y1, ty + kRasterTile);
    bool textured = raster_textured(tri.object);
    bool perspective = view.perspective != 0u;
    Uint64s keys = Uint64s(pc.p.keys);
    RasterEdges row = raster_edges_at(t, x0, y0);
    for (int y = y0; y < y1; ++y, row = raster_step_y(t, row)) {
      RasterEdges e = row;
      for (int x = x0; x < x1; ++x, e = raster_step_x(t, e)) {
        if (!raster_inside(e)) continue;
        // The CPU's span starts at the later of its 64-texel tile's first column and the box's.
        int span_x0 = max(t.x0, (x / kRasterCpuTile) * kRasterCpuTile);
        float z = raster_linear_depth(raster_plane_value(t, x, y, span_x0), view.near, view.far, perspective);
        if (textured && !(raster_fragment_opacity(view, tri.object, tri.prim, x, y) > 0.0f)) continue;
        ++fragments;
        atomicMin(keys.v[uint(y) * uint(view.width) + uint(x)], raster_depth_key(z, t.source));
      }
    }
  }
  uint total = subgroupAdd(fragments);
  if (subgroupElect() && total > 0u) atomicAdd(state.s.fragments, uint64_t(total));
}
