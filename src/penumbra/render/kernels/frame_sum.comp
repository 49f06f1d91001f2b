#version 460
// Progressive frames (RenderSettings::frames): mode 0 adds this frame's V (and E) into the sums,
// mode 1 replaces V (and E) by the sums' means.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/render/frame_kernels_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { FrameSumParams p; } pc;

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.slots) return;
  Floats v = Floats(pc.p.visibility), vs = Floats(pc.p.visibility_sum);
  if (pc.p.mode == 0u) {
    vs.v[i] += v.v[i];
    if (pc.p.irradiance != 0UL) Vec3s(pc.p.irradiance_sum).v[i] += Vec3s(pc.p.irradiance).v[i];
  } else {
    v.v[i] = vs.v[i] * pc.p.inv_frames;
    if (pc.p.irradiance != 0UL) Vec3s(pc.p.irradiance).v[i] = Vec3s(pc.p.irradiance_sum).v[i] * pc.p.inv_frames;
  }
}
