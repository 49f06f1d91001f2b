#version 460
// `occlusion-textures` on the GPU, prefilter=mipmap (eisemann2006 §3.2; prefilter.cpp
// MipmapFilter::build): level l's texel as the rounded mean of the 2 x 2 texels of level l - 1
// below it (clamped to its edge), one thread per texel and slice.
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
  int x = int(texel % uint(pc.p.dst_width)), y = int(texel / uint(pc.p.dst_width));
  Bytes b = Bytes(pc.p.bytes);
  uint src = pc.p.src_offset + k * pc.p.src_plane;
  uint ra = src + uint(min(2 * y, pc.p.src_height - 1)) * uint(pc.p.src_width);
  uint rb = src + uint(min(2 * y + 1, pc.p.src_height - 1)) * uint(pc.p.src_width);
  uint xa = uint(min(2 * x, pc.p.src_width - 1)), xb = uint(min(2 * x + 1, pc.p.src_width - 1));
  uint sum = uint(b.v[ra + xa]) + uint(b.v[ra + xb]) + uint(b.v[rb + xa]) + uint(b.v[rb + xb]) + 2u;
  b.v[pc.p.dst_offset + i] = uint8_t(sum >> 2);
}
