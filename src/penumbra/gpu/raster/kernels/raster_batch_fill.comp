#version 460
// The batch mode's fill (gpu/raster/raster_batch_layout_shared.h): one thread per work item, a
// set-up triangle and one 16 x 16-texel tile of its view, scanned by raster_scan.glsl as the one
// map's fill (raster_fill.comp) scans it, each fragment's key going by atomicMin into that view's
// keys.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_batch_layout_shared.h"
#include "penumbra/gpu/raster/raster_access.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterBatchFillParams p; } pc;
layout(buffer_reference, scalar) readonly buffer BatchViews { GpuRasterBatchView v[]; };
layout(buffer_reference, scalar) readonly buffer BatchTriangles { GpuRasterBatchTriangle v[]; };

// The view's first texel in the batch's keys (set per work item before the scan).
uint64_t g_first_texel = 0UL;

void raster_visit(uint texel, float z, uint source, float opacity) {
  atomicMin(Uint64s(pc.p.keys + g_first_texel * 8UL).v[texel], raster_depth_key(z, source));
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
    GpuRasterItem item = RasterItems(pc.p.items).v[i];
    GpuRasterBatchTriangle tri = BatchTriangles(pc.p.triangles).v[item.triangle];
    GpuRasterBatchView view = BatchViews(pc.p.views).v[tri.view];
    g_first_texel = view.first_texel;
    fragments = raster_scan_tile(view.view, tri.t.s, tri.t.object, tri.t.prim, item.tile, false);
  }
  uint total = subgroupAdd(fragments);
  if (subgroupElect() && total > 0u) atomicAdd(state.s.fragments, uint64_t(total));
}
