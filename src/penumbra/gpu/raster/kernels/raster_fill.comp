#version 460
// The GPU rasterizer's fill (gpu/raster/raster_layout_shared.h; rasterizer.cpp depth_map): one
// thread per work item, a set-up triangle and one 16 x 16-texel tile, its fragments scanned by
// raster_scan.glsl. The fragment's key (ordered z bits << 32 | input index) goes into the texel by
// atomicMin: the nearest surface, ties to the first triangle in input order, as the CPU's strict
// depth test in input order keeps.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterFillParams p; } pc;

void raster_visit(uint texel, float z, uint source, float opacity) {
  atomicMin(Uint64s(pc.p.keys).v[texel], raster_depth_key(z, source));
}

#include "penumbra/gpu/raster/raster_scan.glsl"

void main() {
  uint i = pn_thread_index();
  RasterStateRef state = RasterStateRef(pc.p.state);
  // raster_fill_args dispatched nothing past the items written (none after an overflow).
  uint items = uint(min(state.s.item_count, uint64_t(pc.p.item_capacity)));
  uint fragments = 0u;
  if (i < items) {
    scene_bind(pc.p.scene);
    RasterView view = RasterViewRef(pc.p.view).v;
    fragments = raster_scan_item(view, pc.p.items, pc.p.triangles, i, false);
  }
  uint total = subgroupAdd(fragments);
  if (subgroupElect() && total > 0u) atomicAdd(state.s.fragments, uint64_t(total));
}
