#version 460
// `reference` on the GPU (reference.cpp, shadow_rays.cpp trace_light_fans): per view sample, n
// stratified light samples drawn by the CPU's generator with the CPU's key (seed, light, camera
// ray, frame), warped by scene/light_shared.h's samplers, each traced as a shadow segment
// through the scene (gpu/bvh_traverse.glsl). The same estimators:
//   solid angle: E = L/n sum T_i cos(n, w_i) / pdf_i,  V = sum T_i a_i / sum a_i
//   area:        E = L A/n sum T_i cos cos_l / d^2,    V = mean T_i
// One thread per view sample; rays counted per subgroup, then one atomic.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/gpu/light_access.glsl"
#include "penumbra/core/rng_shared.h"
#include "penumbra/shadow/shadow_rays_shared.h"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

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
      GpuLight light = LightRef(pc.p.light).v;
      LightGeometry L = light.geometry;
      RngState rng = rng_keyed(pc.p.seed, uint64_t(0x52454600u + uint(pc.p.light_index)), gpu_sample_key(s),
                               uint64_t(pc.p.frame));
      LightSampler S = light_sampler_init(L, light.textured != 0u, s.p);
      bool solid_angle = pc.p.area_sampling == 0u && S.mode != kSamplerNone;
      // Area mode: the emitter's normal and area (a sphere's disk faces p; an ellipsoid's
      // central ellipse toward p has its own plane).
      vec3 emit_n = L.n;
      float emit_area = L.area;
      if (!solid_angle && L.shape == kLightEllipsoid && light_faces(L, s.p)) {
        LightEllipse e = light_section_toward(L, s.p);
        emit_n = e.normal;
        emit_area = e.area;
      }
      float eps = ray_offset_epsilon(s.p);
      float len = length(s.ng);
      vec3 n_unit = len > 0.0f ? s.ng / len : vec3(0.0f);
      float e = 0.0f, v = 0.0f, wsum = 0.0f;
      for (int k = 0; k < pc.p.n; ++k) {
        vec2 u = stratified_cell(k, pc.p.grid_cols, pc.p.inv_cols, pc.p.inv_rows, rng_next_2d(rng));
        vec3 d;
        float f, a;
        if (solid_angle) {
          vec3 dir;
          float dist, pdf;
          if (!gpu_light_sample(light, S, u, dir, dist, pdf, a)) continue;
          d = dir * dist;
          f = max(0.0f, dot(s.ns, d)) / dist * (1.0f / pdf);
        } else {
          d = gpu_light_sample_area_toward(light, u, s.p) - s.p;
          float dist2 = dot(d, d);
          vec3 w = d / sqrt(dist2);
          float cos_l = L.shape == kLightSphere      ? 1.0f
                        : L.shape == kLightEllipsoid ? abs(dot(w, emit_n))
                                                     : max(0.0f, -dot(w, L.n));
          f = max(0.0f, dot(s.ns, w)) * cos_l * emit_area / dist2;
          a = 1.0f;
        }
        vec3 org, dir;
        fan_segment(s.p, n_unit, eps, d, org, dir);
        float t = trace_transmittance(org, dir, kFanTfar);
        e += t * f;
        v += t * a;
        wsum += a;
        ++traced;
      }
      Floats(pc.p.visibility).v[i] = wsum > 0.0f ? v / wsum : 0.0f;
      Vec3s(pc.p.irradiance).v[i] = light.radiance * (e / float(pc.p.n));
    }
  }
  uint total = subgroupAdd(traced);
  if (subgroupElect() && total > 0u) atomicAdd(Uint64s(pc.p.rays).v[0], uint64_t(total));
}
