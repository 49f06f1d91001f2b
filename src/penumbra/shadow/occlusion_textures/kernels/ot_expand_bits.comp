#version 460
// `occlusion-textures` on the GPU: level 0 of the 8-bit pyramids (prefilter.cpp expand_bits): one
// plane per slice, 255 where the slice covers the texel, one thread per texel and slice.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/core/shader_compat_math.h"
#include "penumbra/shadow/occlusion_textures/occlusion_kernels_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { OtPyramidParams p; } pc;

void main() {
  uint i = pn_thread_index();
  uint plane = pc.p.dst_plane;
  if (i >= plane * uint(pc.p.slices)) return;
  uint k = i / plane, texel = i % plane;
  uint bit = (Uints(pc.p.masks).v[texel] >> k) & 1u;
  Bytes(pc.p.bytes).v[pc.p.dst_offset + i] = uint8_t(bit * 255u);
}
