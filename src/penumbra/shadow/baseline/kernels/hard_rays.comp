#version 460
// `hard` on the GPU (hard.cpp, shadow_rays.cpp transmittance_to_point): one shadow segment per
// view sample to the light's centre, its transmittance through the scene.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/shadow/shadow_rays_shared.h"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { PointRaysParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.slots) return;
  GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
  if (s.object == kMissObject) return;
  scene_bind(pc.p.scene);
  vec3 org, dir;
  float tfar;
  shadow_segment(s.p, s.ng, pc.p.target, org, dir, tfar);
  Floats(pc.p.visibility).v[i] = trace_transmittance(org, dir, tfar);
}
