#version 460
// `occlusion-textures` on the GPU, thin_fix (eisemann2006 §3.4, Fig. 6): what a slice holds is
// also written into the next slice farther from the light, one thread per texel
// (occlusion_textures.cpp build).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/occlusion_textures/occlusion_kernels_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { OtMaskParams p; } pc;

void main() {
  uint i = pn_thread_index();
  if (i >= uint(pc.p.width) * uint(pc.p.height)) return;
  Uints m = Uints(pc.p.masks);
  uint v = m.v[i];
  m.v[i] = v | ((v << 1) & pc.p.all);
}
