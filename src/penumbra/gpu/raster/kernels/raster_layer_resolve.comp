#version 460
// The GPU rasterizer's layered depth map, one layer's resolve (gpu/raster/raster_modes_shared.h):
// one thread per texel turns the peel's nearest candidate into layer `layer` (linear depth, window
// depth, the fragment's opacity at the texel centre, input triangle), counts it, and makes it the
// front the next peel compares with (+inf where the texel has no more layers). The first layer's
// smallest z goes into GpuRasterState::z_min_bits.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/gpu/raster/raster_modes_shared.h"
#include "penumbra/raster/depth_image_walk_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterLayerResolveParams p; } pc;

void main() {
  RasterView view = RasterViewRef(pc.p.view).v;
  uint i = pn_thread_index();
  uint z_bits = 0xffffffffu;
  if (i < uint(view.width) * uint(view.height)) {
    uint64_t key = Uint64s(pc.p.keys).v[i];
    if (key == ~0UL) {
      Floats(pc.p.front).v[i] = pn_inf();
    } else {
      scene_bind(pc.p.scene);
      float z = raster_key_depth(key);
      uint g = uint(key & 0xffffffffUL);
      uint object, prim;
      raster_source(g, object, prim);
      int x = int(i % uint(view.width)), y = int(i / uint(view.width));
      float opacity =
          raster_textured(object) ? raster_fragment_opacity(view, object, prim, x, y) : raster_opacity(object, prim);
      uint slot = (i * pc.p.k + pc.p.layer) * 4u;
      Floats samples = Floats(pc.p.samples);
      samples.v[slot] = z;
      samples.v[slot + 1u] = view_window_depth(view, z);
      samples.v[slot + 2u] = opacity;
      Uints(pc.p.samples).v[slot + 3u] = g;
      Uints(pc.p.counts).v[i] = pc.p.layer + 1u;
      Floats(pc.p.front).v[i] = z;
      if (pc.p.layer == 0u) z_bits = raster_order_bits(z);
    }
  }
  z_bits = subgroupMin(z_bits);
  if (subgroupElect() && z_bits != 0xffffffffu) atomicMin(RasterStateRef(pc.p.state).s.z_min_bits, z_bits);
}
