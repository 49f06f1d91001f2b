// A light on the GPU (gpu/light_layout_shared.h) and the sampling around it: the untextured
// warps of scene/light_shared.h plus a textured light's table, as AreaLight::sample_area and
// LightPointSampler::sample do on the CPU.
#ifndef PENUMBRA_GPU_LIGHT_ACCESS_GLSL
#define PENUMBRA_GPU_LIGHT_ACCESS_GLSL

#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/light_layout_shared.h"

layout(buffer_reference, scalar) readonly buffer LightRef { GpuLight v; };

// u warped through a textured light's table (PiecewiseConstant2D::sample); u itself otherwise.
vec2 light_table_warp(GpuLight light, vec2 u) {
  if (light.textured == 0u) return u;
  return piecewise_constant_2d_sample(Floats(light.marginal), Floats(light.conditional), light.table_width,
                                      light.table_height, u);
}

// AreaLight::sample_area and sample_area_toward, textured lights included.
vec3 gpu_light_sample_area(GpuLight light, vec2 u) { return light_sample_area(light.geometry, light_table_warp(light, u)); }
vec3 gpu_light_sample_area_toward(GpuLight light, vec2 u, vec3 p) {
  return light_sample_area_toward(light.geometry, light_table_warp(light, u), p);
}

// LightPointSampler::sample: area-mode samples of a textured light follow its table.
bool gpu_light_sample(GpuLight light, LightSampler S, vec2 u, out vec3 dir, out float dist, out float pdf,
                      out float area_weight) {
  if (S.mode == kSamplerArea) u = light_table_warp(light, u);
  return light_sampler_sample(S, light.geometry, u, dir, dist, pdf, area_weight);
}

#endif
