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
#include "penumbra/gpu/raster/raster_stages.glsl"

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
    GpuRasterItem item = RasterItems(pc.p.items).v[i];
    GpuRasterTriangle tri = RasterTriangles(pc.p.triangles).v[item.triangle];
    fragments = raster_fill_tile(RasterViewRef(pc.p.view).v, tri.s, tri.object, tri.prim, item.tile, pc.p.keys, 0UL);
  }
  uint total = subgroupAdd(fragments);
  if (subgroupElect() && total > 0u) atomicAdd(state.s.fragments, uint64_t(total));
}
