#version 460
// Test kernel (gpu/shared_functions_test.cpp): light_shared.h and sampling_shared.h on the GPU.
// Per point p (with normal n): the sampler's mode, `draws` samples of u from the point's
// (u.x, u.y) list, and the unshadowed irradiance, to compare with the CPU's.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/scene/light_shared.h"

layout(local_size_x = 64) in;
layout(buffer_reference, scalar) readonly buffer LightRef { LightGeometry v; };
layout(push_constant, scalar) uniform Push {
  LightRef light;
  Vec3s points;    // p, n per point
  Vec2s u;         // `draws` per point
  Floats out_samples;  // per point and draw: dir (3), dist, pdf, area_weight, ok (7 floats)
  Floats out_irradiance;  // per point: mode, irradiance
  Floats unit_circle;
  uint count;
  uint draws;
} pc;

void main() {
  uint i = pn_thread_index();
  if (i >= pc.count) return;
  LightGeometry L = pc.light.v;
  vec3 p = pc.points.v[2 * i], n = pc.points.v[2 * i + 1];
  LightSampler S = light_sampler_init(L, false, p);
  for (uint k = 0; k < pc.draws; ++k) {
    vec3 dir;
    float dist, pdf, w;
    bool ok = S.mode != kSamplerNone && light_sampler_sample(S, L, pc.u.v[i * pc.draws + k], dir, dist, pdf, w);
    uint o = 7u * (i * pc.draws + k);
    pc.out_samples.v[o] = dir.x;
    pc.out_samples.v[o + 1] = dir.y;
    pc.out_samples.v[o + 2] = dir.z;
    pc.out_samples.v[o + 3] = dist;
    pc.out_samples.v[o + 4] = pdf;
    pc.out_samples.v[o + 5] = w;
    pc.out_samples.v[o + 6] = ok ? 1.0f : 0.0f;
  }
  pc.out_irradiance.v[2 * i] = float(S.mode);
  pc.out_irradiance.v[2 * i + 1] = light_irradiance(L, p, n, pc.unit_circle);
}
