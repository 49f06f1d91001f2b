#version 460
// One light's contribution to each view sample (Renderer::render's compose): a method that gives
// V only is multiplied with the closed-form unshadowed irradiance (scene/light_shared.h); the
// Lambertian radiance albedo / pi E and the irradiance-weighted V are summed over the lights.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/light_access.glsl"
#include "penumbra/render/frame_kernels_shared.h"
#include "penumbra/shadow/view_samples_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { ComposeParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.slots) return;
  GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
  if (s.object == kMissObject) return;
  GpuLight light = LightRef(pc.p.light).v;
  vec3 e0 = light.radiance * light_irradiance(light.geometry, s.p, s.ns, Floats(pc.p.unit_circle));
  // Renderer::render's rule: V = 0 where the light's emitting side does not face the point.
  float v = light_faces(light.geometry, s.p) ? clamp(Floats(pc.p.visibility).v[i], 0.0f, 1.0f) : 0.0f;
  vec3 e = pc.p.has_irradiance != 0u ? Vec3s(pc.p.irradiance).v[i] : e0 * v;
  Vec3s(pc.p.radiance).v[i] += s.albedo * e * 0.31830988618379067154f;
  float w = 0.2126f * e0.x + 0.7152f * e0.y + 0.0722f * e0.z;  // luminance
  Floats(pc.p.v_weighted).v[i] += w * v;
  Floats(pc.p.v_weight).v[i] += w;
  Floats(pc.p.v_plain).v[i] += v;
}
