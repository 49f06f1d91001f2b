#version 460
// `vsm`, `evsm`, `msm` on the GPU (filtered_moments/filtered_moments_kernels_shared.h): the
// smallest and largest covered depth of the light-centre map (FilteredMomentMap::build's first
// loop), as order bits: a subgroup's extremes, then one atomic each.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/filtered_moments/filtered_moments_kernels_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { FmDepthRangeParams p; } pc;
layout(buffer_reference, scalar) buffer DepthBitsRef { FmDepthBits b; };

void main() {
  uint i = pn_thread_index();
  uint lo = 0xffffffffu, hi = 0u;
  if (i < pc.p.texels) {
    float z = Floats(pc.p.z).v[i];
    if (floatBitsToUint(z) < 0x7f800000u) {  // z < +inf (depths are positive), from the bits
      lo = raster_order_bits(z);
      hi = lo;
    }
  }
  lo = subgroupMin(lo);
  hi = subgroupMax(hi);
  if (subgroupElect() && hi != 0u) {
    DepthBitsRef r = DepthBitsRef(pc.p.bits);
    atomicMin(r.b.lo, lo);
    atomicMax(r.b.hi, hi);
  }
}
