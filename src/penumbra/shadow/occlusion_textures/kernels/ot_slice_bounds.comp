#version 460
// `occlusion-textures` on the GPU: each slice's covered rectangle (prefilter.cpp coverage_bounds),
// for the pyramids' elongated kernels: per slice a subgroup's extremes of the covered texels, then
// one atomic each, on the floats' bits (order-preserving for floats >= 0).
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/occlusion_textures/occlusion_kernels_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { OtMaskParams p; } pc;

void main() {
  uint i = pn_thread_index();
  uint texels = uint(pc.p.width) * uint(pc.p.height);
  uint mask = i < texels ? Uints(pc.p.masks).v[i] : 0u;
  uint x = i % uint(pc.p.width), y = i / uint(pc.p.width);
  Uints bounds = Uints(pc.p.bounds);
  for (int k = 0; k < pc.p.slices; ++k) {
    bool covered = ((mask >> uint(k)) & 1u) != 0u;
    uint x0 = subgroupMin(covered ? floatBitsToUint(float(x)) : 0xffffffffu);
    uint y0 = subgroupMin(covered ? floatBitsToUint(float(y)) : 0xffffffffu);
    uint x1 = subgroupMax(covered ? floatBitsToUint(float(x + 1u)) : 0u);
    uint y1 = subgroupMax(covered ? floatBitsToUint(float(y + 1u)) : 0u);
    if (subgroupElect() && x1 != 0u) {
      atomicMin(bounds.v[4 * k], x0);
      atomicMin(bounds.v[4 * k + 1], y0);
      atomicMax(bounds.v[4 * k + 2], x1);
      atomicMax(bounds.v[4 * k + 3], y1);
    }
  }
}
