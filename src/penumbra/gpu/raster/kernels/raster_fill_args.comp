#version 460
// The indirect dispatch of raster_fill (gpu/raster/raster_layout_shared.h): one thread turns the
// work items raster_setup wrote into group counts, folded into two dimensions as
// CommandList::dispatch folds long grids (kernel_common.glsl pn_thread_index unfolds them). When
// a buffer overflowed, no fill: the items past the last one that fitted were never written, and
// the host renders again with larger buffers anyway.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"

layout(local_size_x = 1) in;
layout(push_constant, scalar) uniform Push { RasterFillParams p; } pc;

// raster_fill's local size.
const uint kFillGroup = 64u;

void main() {
  RasterStateRef state = RasterStateRef(pc.p.state);
  bool overflowed = state.s.setup_count > pc.p.triangle_capacity || state.s.item_count > uint64_t(pc.p.item_capacity);
  uint items = overflowed ? 0u : uint(state.s.item_count);
  uvec3 groups = pn_indirect_groups(items, kFillGroup);
  state.s.fill_groups_x = groups.x;
  state.s.fill_groups_y = groups.y;
  state.s.fill_groups_z = groups.z;
}
