#version 460
// The GPU rasterizer's resolve (gpu/raster/raster_layout_shared.h): one thread per texel turns
// the nearest fragment's key into the DepthMap planes (raster/depth_map.h): linear depth, window
// depth (LightView::window_depth), the surface's opacity at the texel centre (material x
// triangle x alpha texture, as the fragment had it) and the input triangle; empty texels get
// +inf, +inf, 0 and kNoTriangle. The map's smallest z goes into GpuRasterState::z_min_bits.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_stages.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterResolveParams p; } pc;

void main() {
  RasterView view = RasterViewRef(pc.p.view).v;
  uint i = pn_thread_index();
  uint z_bits = 0xffffffffu;  // this texel's share of the map's smallest z (none: the identity)
  if (i < uint(view.width) * uint(view.height)) {
    uint64_t key = Uint64s(pc.p.keys).v[i];
    if (key != ~0UL) scene_bind(pc.p.scene);
    float z, depth, opacity;
    uint triangle;
    raster_resolve_key(view, key, int(i % uint(view.width)), int(i / uint(view.width)), z, depth, opacity, triangle);
    Floats(pc.p.z).v[i] = z;
    Floats(pc.p.depth).v[i] = depth;
    Floats(pc.p.opacity).v[i] = opacity;
    Uints(pc.p.triangle).v[i] = triangle;
    if (key != ~0UL) z_bits = raster_order_bits(z);
  }
  // One atomic per subgroup.
  z_bits = subgroupMin(z_bits);
  if (subgroupElect() && z_bits != 0xffffffffu) atomicMin(RasterStateRef(pc.p.state).s.z_min_bits, z_bits);
}
