#version 460
// `occlusion-textures` on the GPU, prefilter=nbuffer (eisemann2006 §3.2, Décoret's N-buffers;
// prefilter.cpp NBufferFilter::build): level l + 1 at anchor (x, y) as the rounded mean of level l
// at (x, y), (x + n, y), (x, y + n), (x + n, y + n), n = 2^l: four lookups per texel, one thread
// per anchor and slice.
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
  uint x = texel % uint(pc.p.dst_width), y = texel / uint(pc.p.dst_width);
  uint n = uint(pc.p.step), w = uint(pc.p.src_width);
  Bytes b = Bytes(pc.p.bytes);
  uint a = pc.p.src_offset + k * pc.p.src_plane + y * w + x, c = a + n * w;
  uint sum = uint(b.v[a]) + uint(b.v[a + n]) + uint(b.v[c]) + uint(b.v[c + n]) + 2u;
  b.v[pc.p.dst_offset + i] = uint8_t(sum >> 2);
}
