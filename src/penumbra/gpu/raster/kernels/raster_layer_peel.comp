#version 460
// One peel of the GPU rasterizer's layered depth map (gpu/raster/raster_modes_shared.h;
// rasterizer.cpp layered_depth_map): one thread per work item, its fragments scanned by
// raster_scan.glsl. xie2007 §4.2 peels the layers with the hardware depth test, one pass per layer
// against the last one's depths; here each pass keeps, by atomicMin of (ordered z bits << 32 |
// input index), the nearest fragment that lies behind the texel's front as a distinct surface
// (raster/raster_layers_shared.h, the CPU's rule), whatever order the GPU runs fragments in. A
// fragment within epsilon of the front joins that layer instead: its opacity is composed into the
// layer's (an atomic compare-and-swap loop: the product's rounding may follow another order than
// the CPU's input order).
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/gpu/raster/raster_modes_shared.h"
#include "penumbra/raster/raster_layers_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterPeelParams p; } pc;

void raster_visit(uint texel, float z, uint source, float opacity) {
  float front = Floats(pc.p.front).v[texel];
  bool behind = raster_layer_behind(z, front, pc.p.epsilon);
  if (behind && pc.p.layer < pc.p.k) {
    atomicMin(Uint64s(pc.p.keys).v[texel], raster_depth_key(z, source));
    return;
  }
  if (behind || pc.p.layer == 0u || !(z >= front)) return;
  // Joins layer - 1, unless it is that layer's front itself.
  Uints samples = Uints(pc.p.samples);
  uint slot = (texel * pc.p.k + pc.p.layer - 1u) * 4u;
  if (samples.v[slot + 3u] == source && uintBitsToFloat(samples.v[slot]) == z) return;
  uint old = samples.v[slot + 2u];
  for (;;) {
    uint want = floatBitsToUint(raster_layer_opacity(uintBitsToFloat(old), opacity));
    uint seen = atomicCompSwap(samples.v[slot + 2u], old, want);
    if (seen == old) break;
    old = seen;
  }
}

#include "penumbra/gpu/raster/raster_scan.glsl"

void main() {
  uint i = pn_thread_index();
  RasterStateRef state = RasterStateRef(pc.p.state);
  uint items = uint(min(state.s.item_count, uint64_t(pc.p.item_capacity)));
  uint fragments = 0u;
  if (i < items) {
    scene_bind(pc.p.scene);
    RasterView view = RasterViewRef(pc.p.view).v;
    fragments = raster_scan_item(view, pc.p.items, pc.p.triangles, i, true);
  }
  // The fragments are counted once, in the first peel (RasterStats::fragments).
  uint total = subgroupAdd(fragments);
  if (pc.p.layer == 0u && subgroupElect() && total > 0u) atomicAdd(state.s.fragments, uint64_t(total));
}
