#version 460
// The GPU rasterizer's fragment lists, first pass (gpu/raster/raster_modes_shared.h): one thread
// per work item counts its fragments into their texels (raster_scan.glsl); the counts' prefix sum
// (gpu/scan_gpu.h) then places each texel's list.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/gpu/raster/raster_modes_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterFragmentParams p; } pc;

void raster_visit(uint texel, float z, uint source, float opacity) { atomicAdd(Uints(pc.p.counts).v[texel], 1u); }

#include "penumbra/gpu/raster/raster_scan.glsl"

void main() {
  uint i = pn_thread_index();
  RasterStateRef state = RasterStateRef(pc.p.state);
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
