// A view sample's fan of light samples on the GPU (shadow/shadow_rays.cpp draw_light_fan and
// trace_light_fans): n stratified light samples drawn by the CPU's generator with the CPU's key
// (seed, light, camera ray, frame), warped by scene/light_shared.h's samplers, each traced as a
// shadow segment through the scene (gpu/bvh_traverse.glsl). Kernels that trace the reference's
// fans include this (reference_fans.comp, rt-denoised's dn_fans.comp), so they draw the same
// samples. Bind the scene first (scene_bind).
#ifndef PENUMBRA_SHADOW_LIGHT_FANS_GLSL
#define PENUMBRA_SHADOW_LIGHT_FANS_GLSL

#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/gpu/light_access.glsl"
#include "penumbra/core/rng_shared.h"
#include "penumbra/core/sampling_shared.h"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

struct LightFan {
  GpuLight light;
  LightSampler light_sampler;
  RngState rng;
  bool solid_angle;  // solid-angle samples (else uniform area samples)
  vec3 emit_n;       // area samples: the emitter's normal and area
  float emit_area;
  vec3 p;
  float eps;
  vec3 ns;
  vec3 n_unit;
  int grid_cols;  // StratifiedGrid(n)
  float inv_cols;
  float inv_rows;
};

LightFan light_fan_begin(uint64_t light_address, uint64_t seed, int light_index, int frame, bool area_sampling,
                         int grid_cols, float inv_cols, float inv_rows, GpuViewSample s) {
  LightFan fan;
  fan.light = LightRef(light_address).v;
  LightGeometry L = fan.light.geometry;
  fan.rng = rng_keyed(seed, uint64_t(0x52454600u + uint(light_index)), gpu_sample_key(s), uint64_t(frame));
  fan.light_sampler = light_sampler_init(L, fan.light.textured != 0u, s.p);
  fan.solid_angle = !area_sampling && fan.light_sampler.mode != kSamplerNone;
  // Area mode: the emitter's normal and area (a sphere's disk faces p; an ellipsoid's central
  // ellipse toward p has its own plane).
  fan.emit_n = L.n;
  fan.emit_area = L.area;
  if (!fan.solid_angle && L.shape == kLightEllipsoid && light_faces(L, s.p)) {
    LightEllipse e = light_section_toward(L, s.p);
    fan.emit_n = e.normal;
    fan.emit_area = e.area;
  }
  fan.p = s.p;
  fan.ns = s.ns;
  fan.eps = ray_offset_epsilon(s.p);
  float len = length(s.ng);
  fan.n_unit = len > 0.0f ? s.ng / len : vec3(0.0f);
  fan.grid_cols = grid_cols;
  fan.inv_cols = inv_cols;
  fan.inv_rows = inv_rows;
  return fan;
}

// Sample k of the fan (drawn in order k = 0, 1, ...): false where the sampler gives none (the
// CPU's batch leaves it out); else its transmittance t, its term f of the irradiance estimate
// (solid angle: cos / dist / pdf; area: cos cos_l A / d^2) and its area weight a.
bool light_fan_trace(inout LightFan fan, int k, out float t, out float f, out float a) {
  LightGeometry L = fan.light.geometry;
  vec2 u = stratified_cell(k, fan.grid_cols, fan.inv_cols, fan.inv_rows, rng_next_2d(fan.rng));
  t = 0.0f;
  f = 0.0f;
  a = 0.0f;
  vec3 d;
  if (fan.solid_angle) {
    vec3 dir;
    float dist, pdf;
    if (!gpu_light_sample(fan.light, fan.light_sampler, u, dir, dist, pdf, a)) return false;
    d = dir * dist;
    f = max(0.0f, dot(fan.ns, d)) / dist * (1.0f / pdf);
  } else {
    d = gpu_light_sample_area_toward(fan.light, u, fan.p) - fan.p;
    float dist2 = dot(d, d);
    vec3 w = d / sqrt(dist2);
    float cos_l = L.shape == kLightSphere      ? 1.0f
                  : L.shape == kLightEllipsoid ? abs(dot(w, fan.emit_n))
                                               : max(0.0f, -dot(w, L.n));
    f = max(0.0f, dot(fan.ns, w)) * cos_l * fan.emit_area / dist2;
    a = 1.0f;
  }
  vec3 org, dir;
  fan_segment(fan.p, fan.n_unit, fan.eps, d, org, dir);
  t = trace_transmittance(org, dir, kFanTfar);
  return true;
}

#endif
