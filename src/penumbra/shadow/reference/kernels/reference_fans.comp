#version 460
// `reference` on the GPU (reference.cpp, shadow_rays.cpp trace_light_fans): per view sample, n
// stratified light samples drawn by the CPU's generator with the CPU's key (seed, light, camera
// ray, frame), warped by scene/light_shared.h's samplers, each traced as a shadow segment
// through the scene (gpu/bvh_traverse.glsl). The same estimators:
//   solid angle: E = L/n sum T_i cos(n, w_i) / pdf_i,  V = sum T_i a_i / sum a_i
//   area:        E = L A/n sum T_i cos cos_l / d^2,    V = mean T_i
// The fans are shadow/light_fans.glsl's. One thread per view sample; rays counted per subgroup,
// then one atomic.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/light_fans.glsl"
#include "penumbra/shadow/shadow_rays_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { LightFansParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };

void main() {
  uint i = pn_thread_index();
  uint traced = 0u;
  if (i < pc.p.slots) {
    GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
    if (s.object != kMissObject) {
      scene_bind(pc.p.scene);
      LightFan fan = light_fan_begin(pc.p.light, pc.p.seed, pc.p.light_index, pc.p.frame, pc.p.area_sampling != 0u,
                                     pc.p.grid_cols, pc.p.inv_cols, pc.p.inv_rows, s);
      float e = 0.0f, v = 0.0f, wsum = 0.0f;
      for (int k = 0; k < pc.p.n; ++k) {
        float t, f, a;
        if (!light_fan_trace(fan, k, t, f, a)) continue;
        e += t * f;
        v += t * a;
        wsum += a;
        ++traced;
      }
      Floats(pc.p.visibility).v[i] = wsum > 0.0f ? v / wsum : 0.0f;
      Vec3s(pc.p.irradiance).v[i] = fan.light.radiance * (e / float(pc.p.n));
    }
  }
  uint total = subgroupAdd(traced);
  if (subgroupElect() && total > 0u) atomicAdd(Uint64s(pc.p.rays).v[0], uint64_t(total));
}
