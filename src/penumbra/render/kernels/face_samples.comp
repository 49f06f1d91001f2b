#version 460
// One face of a split sphere light (scene/light.h split_sphere_lights): a copy of the view
// samples in which every slot the face does not serve (sphere_face, AreaLight::serves) is a
// miss. The face's method and its compose read the copy (Renderer::render's split on the CPU).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/render/frame_kernels_shared.h"
#include "penumbra/scene/light_shared.h"
#include "penumbra/shadow/view_samples_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { FaceSamplesParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) writeonly buffer ViewSamplesOut { GpuViewSample v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.slots) return;
  GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
  if (s.object != kMissObject && sphere_face(pc.p.s, pc.p.t, pc.p.n, pc.p.cube != 0u, s.p - pc.p.center) != pc.p.face)
    s.object = kMissObject;
  ViewSamplesOut(pc.p.served).v[i] = s;
}
