#version 460
// afsm-hard on the GPU: V per view-sample slot from its state and its list position's shadow mark
// (alias_free.cpp AliasFreeHard::evaluate): 0 behind the light or light back-facing on a closed
// mesh, 0 where a caster blocks it, 1 where none covers it; outside the fitted view (which max_fov
// caps), and where only casters that stop part of the light cover it, the transmittance of its
// shadow segment to the centre through the scene (`hard`'s ray: hard_rays.comp).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/shadow/alias_free/alias_free_shared.h"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmHardParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ListedIn { AfsmListed v[]; };
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.count) return;
  uint st = Uints(pc.p.state).v[i];
  if (st == kAfsmMiss) return;
  float v = 1.0f;
  if (st == kAfsmNotListed) {
    v = 0.0f;
  } else {
    uint shadow = st == kAfsmUncovered ? kAfsmCenterPartial : ListedIn(pc.p.listed).v[st].shadow;
    if (shadow == kAfsmCenterBlocked) {
      v = 0.0f;
    } else if (shadow == kAfsmCenterPartial) {
      GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
      scene_bind(pc.p.scene);
      vec3 org, dir;
      float tfar;
      shadow_segment(s.p, s.ng, pc.p.light_center, org, dir, tfar);
      v = trace_transmittance(org, dir, tfar);
    }
  }
  Floats(pc.p.visibility).v[i] = v;
}
