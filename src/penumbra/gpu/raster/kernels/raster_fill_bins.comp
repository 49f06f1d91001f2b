#version 460
// The GPU rasterizer's depth-bin fill (gpu/raster/raster_bins_layout_shared.h; rasterizer.cpp
// depth_bin_masks): one thread per work item, a set-up triangle and one 16 x 16-texel tile. Every
// texel centre of the tile the triangle covers (raster_fill's coverage and depth, the CPU's) is a
// fragment; an alpha-textured triangle's mask holes drop it. The fragment sets the bit of its
// depth bin in the texel's mask by atomicOr: the masks do not depend on the order fragments come
// in.
// eisemann2006 §3.4: the paper writes one colour channel per slice with blending (one
// rasterization pass of the scene, the slice's channel chosen by the fragment's depth); here a
// compute thread ORs the slice's bit into the texel's word.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/gpu/raster/raster_bins_layout_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterBinsFillParams p; } pc;

void main() {
  uint i = pn_thread_index();
  RasterStateRef state = RasterStateRef(pc.p.fill.state);
  uint items = uint(min(state.s.item_count, uint64_t(pc.p.fill.item_capacity)));
  uint fragments = 0u;
  if (i < items) {
    scene_bind(pc.p.fill.scene);
    RasterView view = RasterViewRef(pc.p.fill.view).v;
    GpuRasterItem item = RasterItems(pc.p.fill.items).v[i];
    GpuRasterTriangle tri = RasterTriangles(pc.p.fill.triangles).v[item.triangle];
    RasterSetup t = tri.s;
    int tx = int(item.tile & 0xffffu) << kRasterTileShift, ty = int(item.tile >> 16) << kRasterTileShift;
    int x0 = max(t.x0, tx), x1 = min(t.x1, tx + kRasterTile);
    int y0 = max(t.y0, ty), y1 = min(t.y1, ty + kRasterTile);
    bool textured = raster_textured(tri.object);
    bool perspective = view.perspective != 0u;
    Uints masks = Uints(pc.p.fill.keys);
    RasterEdges row = raster_edges_at(t, x0, y0);
    for (int y = y0; y < y1; ++y, row = raster_step_y(t, row)) {
      RasterEdges e = row;
      for (int x = x0; x < x1; ++x, e = raster_step_x(t, e)) {
        if (!raster_inside(e)) continue;
        int span_x0 = max(t.x0, (x / kRasterCpuTile) * kRasterCpuTile);
        float z = raster_linear_depth(raster_plane_value(t, x, y, span_x0), view.near, view.far, perspective);
        if (textured && !(raster_fragment_opacity(view, tri.object, tri.prim, x, y) > 0.0f)) continue;
        ++fragments;
        atomicOr(masks.v[uint(y) * uint(view.width) + uint(x)], 1u << uint(raster_depth_bin(pc.p.bins, z)));
      }
    }
  }
  uint total = subgroupAdd(fragments);
  if (subgroupElect() && total > 0u) atomicAdd(state.s.fragments, uint64_t(total));
}
