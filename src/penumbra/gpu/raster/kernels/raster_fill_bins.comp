#version 460
// The GPU rasterizer's depth-bin fill (gpu/raster/raster_bins_layout_shared.h; rasterizer.cpp
// depth_bin_masks): one thread per work item, a set-up triangle and one 16 x 16-texel tile. Every
// texel centre of the tile the triangle covers (raster_fill's coverage and depth, the CPU's:
// raster_scan.glsl) is a fragment; an alpha-textured triangle's mask holes drop it. The fragment
// sets the bit of its depth bin in the texel's mask by atomicOr: the masks do not depend on the
// order fragments come in. With `nearest`, it also keeps the bin's nearest depth by atomicMin
// (the CPU's DepthBinMasks::nearest, an order-independent minimum too).
// eisemann2006 §3.4: the paper writes one colour channel per slice with blending (one
// rasterization pass of the scene, the slice's channel chosen by the fragment's depth); here a
// compute thread ORs the slice's bit into the texel's word.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/gpu/raster/raster_bins_layout_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterBinsFillParams p; } pc;
layout(buffer_reference, scalar) readonly buffer TileBins { RasterDepthBins b[]; };

void raster_visit(uint texel, float z, uint source, float opacity) {
  RasterDepthBins bins = pc.p.bins;
  if (pc.p.tile_bins != 0ul) {
    int x = int(texel % uint(pc.p.width)), y = int(texel / uint(pc.p.width));
    bins = TileBins(pc.p.tile_bins).b[raster_bins_tile(x, y, pc.p.tile_shift, pc.p.tile_columns)];
  }
  int k = raster_depth_bin(bins, z);
  atomicOr(Uints(pc.p.fill.keys).v[texel], 1u << uint(k));
  // The bin's nearest depth (z >= 0: its bits order as the floats do).
  if (pc.p.nearest != 0ul) atomicMin(Uints(pc.p.nearest).v[uint(k) * pc.p.plane + texel], floatBitsToUint(max(z, 0.0f)));
}

#include "penumbra/gpu/raster/raster_scan.glsl"

void main() {
  uint i = pn_thread_index();
  RasterStateRef state = RasterStateRef(pc.p.fill.state);
  uint items = uint(min(state.s.item_count, uint64_t(pc.p.fill.item_capacity)));
  uint fragments = 0u;
  if (i < items) {
    scene_bind(pc.p.fill.scene);
    RasterView view = RasterViewRef(pc.p.fill.view).v;
    fragments = raster_scan_item(view, pc.p.fill.items, pc.p.fill.triangles, i, false);
  }
  uint total = subgroupAdd(fragments);
  if (subgroupElect() && total > 0u) atomicAdd(state.s.fragments, uint64_t(total));
}
