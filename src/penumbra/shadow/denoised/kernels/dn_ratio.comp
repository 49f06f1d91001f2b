#version 460
// `rt-denoised` on the GPU, every valid slot (the CPU's denoised.cpp output loop): V, the denoised
// area fraction (atrous_shared.h dn_visibility), and E, the ratio of the denoised estimates
// (Heitz et al. 2018 §3.2; dn_ratio) times the closed-form unshadowed irradiance
// (scene/light_shared.h light_irradiance, as compose.comp).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/light_access.glsl"
#include "penumbra/shadow/denoised/denoise_image.glsl"
#include "penumbra/shadow/view_samples_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { DnFilterParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.slots) return;
  DnPlanes planes = DnPlanesRef(pc.p.planes).p;
  int x, y;
  DenoiseImage img = dn_slot_image(planes, pc.p, i, x, y);
  if (!dn_valid(img, i)) return;
  Floats(pc.p.visibility).v[i] = dn_visibility(img, i);
  GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
  GpuLight light = LightRef(pc.p.light).v;
  vec3 e0 = light.radiance * light_irradiance(light.geometry, s.p, s.ns, Floats(pc.p.unit_circle));
  Vec3s(pc.p.irradiance).v[i] = e0 * dn_ratio(img, i);
}
