#version 460
// `reference` on the GPU (reference.cpp, shadow_rays.cpp trace_light_fans): per view sample, n
// stratified light samples drawn by the CPU's generator with the CPU's key (seed, light, camera
// ray, frame), warped by scene/light_shared.h's samplers, each traced as a shadow segment
// through the scene (gpu/bvh_traverse.glsl). The same estimators:
//   solid angle: E = L/n sum T_i cos(n, w_i) / pdf_i,  V = sum T_i a_i / sum a_i
//   area:        E = L A/n sum T_i cos cos_l / d^2,    V = mean T_i
// The fans are shadow/light_fans.glsl's. One thread per view sample for the samples [first,
// first + count) (ReferenceFansParams: one dispatch for all n where the driver has no loop
// limit); rays counted per subgroup, then one atomic.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/light_fans.glsl"
#include "penumbra/shadow/shadow_rays_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { ReferenceFansParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };

void main() {
  uint i = pn_thread_index();
  uint traced = 0u;
  LightFansParams lf = pc.p.fans;
  if (i < lf.slots) {
    GpuViewSample s = ViewSamplesIn(lf.samples).v[i];
    if (s.object != kMissObject) {
      scene_bind(lf.scene);
      LightFan fan = light_fan_begin(lf.light, lf.seed, lf.light_index, lf.frame, lf.area_sampling != 0u,
                                     lf.grid_cols, lf.inv_cols, lf.inv_rows, s);
      vec3 sums = pc.p.first == 0 ? vec3(0.0f) : Vec3s(pc.p.partial).v[i];  // e, sum T a, sum a
      int end = min(pc.p.first + pc.p.count, lf.n);
      for (int k = pc.p.first; k < end; ++k) {
        float t, f, a;
        if (!light_fan_trace(fan, k, t, f, a)) continue;
        sums.x += t * f;
        sums.y += t * a;
        sums.z += a;
        ++traced;
      }
      if (end < lf.n) {
        Vec3s(pc.p.partial).v[i] = sums;
      } else {
        Floats(lf.visibility).v[i] = sums.z > 0.0f ? sums.y / sums.z : 0.0f;
        Vec3s(lf.irradiance).v[i] = fan.light.radiance * (sums.x / float(lf.n));
      }
    }
  }
  uint cut = subgroupMax(pn_loop_limit_hit(pc.p.canary) ? 1u : 0u);
  uint total = subgroupAdd(traced);
  if (subgroupElect() && total > 0u) atomicAdd(Uint64s(lf.rays).v[0], uint64_t(total));
  if (subgroupElect() && cut != 0u) atomicMax(Uint64s(lf.rays).v[1], uint64_t(1));
}
