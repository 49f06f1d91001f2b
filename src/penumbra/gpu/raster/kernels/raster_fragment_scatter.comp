#version 460
// The GPU rasterizer's fragment lists, second pass (gpu/raster/raster_modes_shared.h): one thread
// per work item writes each of its fragments (depth, opacity at the texel centre, input triangle)
// into its texel's list, at the texel's offset plus a slot taken from its cursor. A fragment past
// the buffer's capacity is not written: the host reads the total the scan counted, grows the
// buffer and renders again.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/gpu/raster/raster_modes_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterFragmentParams p; } pc;
layout(buffer_reference, scalar) buffer GpuFragments { GpuFragment v[]; };

void raster_visit(uint texel, float z, uint source, float opacity) {
  uint slot = Uints(pc.p.offsets).v[texel] + atomicAdd(Uints(pc.p.counts).v[texel], 1u);
  if (slot >= pc.p.fragment_capacity) return;
  GpuFragment f;
  f.z = z;
  f.opacity = opacity;
  f.triangle = source;
  GpuFragments(pc.p.fragments).v[slot] = f;
}

#include "penumbra/gpu/raster/raster_scan.glsl"

void main() {
  uint i = pn_thread_index();
  RasterStateRef state = RasterStateRef(pc.p.state);
  uint items = uint(min(state.s.item_count, uint64_t(pc.p.item_capacity)));
  if (i >= items) return;
  scene_bind(pc.p.scene);
  RasterView view = RasterViewRef(pc.p.view).v;
  raster_scan_item(view, pc.p.items, pc.p.triangles, i, true);
}
