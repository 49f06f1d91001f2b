#version 460
// afsm on the GPU: each listed entry's slab (the CPU's split_by_depth): one thread per view-sample
// slot. An entry's depth bin (afsm_depth_bin, as afsm_soft_list_count found it) gives its slab;
// its key, slab × texels + texel, is counted (the lists are ordered slab-major, then by texel, so
// the entries of one slab in texels [x0, x1) of a row are one range of positions), and the slab's
// farthest depth kept (its influence regions' far plane, sintorn2008 §4.3).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/shadow/alias_free/kernels/afsm_soft_access.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmSoftParams p; } pc;

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.count) return;
  Uints state = Uints(pc.p.state);
  RasterView view = RasterViewRef(pc.p.view).v;
  uint texels = uint(view.width) * uint(view.height);
  AfsmSlabsRef slabs = afsm_slabs(pc.p.view);
  for (uint e = 2u * i; e < 2u * i + 2u; ++e) {
    uint texel = state.v[e];
    if (texel >= kAfsmUncovered) continue;  // not listed
    float z = raster_project(view, Vec3s(pc.p.points).v[e]).z;
    uint slab = slabs.s.slab_of_bin[afsm_depth_bin(view.near, view.far, z)];
    uint key = slab * texels + texel;
    state.v[e] = key;
    atomicAdd(Uints(pc.p.first).v[key], 1u);
    atomicMax(slabs.s.far_bits[slab], floatBitsToUint(z));  // z >= near > 0: bits order as floats
  }
}
