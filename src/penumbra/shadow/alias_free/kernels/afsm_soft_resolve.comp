#version 460
// afsm on the GPU (alias_free.cpp AliasFreeSoft::evaluate, "resolve"): V per view-sample slot,
// 1 - (blocked light samples over its list entries, less the preset other side of a split
// sample, plus the light the casters that stop only part of it take) / N. The light samples such
// casters cover and no blocking caster blocks (the entry's second mask, where
// AfsmSoftLight::stride holds one) each take the transmittance of their shadow segment through the
// scene (the ray tracer's rule, as ssv_evaluate.comp's); so does every light sample of an entry
// outside the fitted view (which max_fov caps), on its side of a split sample.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/shadow/alias_free/kernels/afsm_soft_access.glsl"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmSoftParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.count) return;
  Uints state = Uints(pc.p.state);
  uint e0 = state.v[2u * i];
  if (e0 == kAfsmMiss) return;
  Floats visibility = Floats(pc.p.visibility);
  if (e0 == kAfsmNotListed) {
    visibility.v[i] = 0.0f;
    return;
  }
  AfsmSoftLight light = AfsmLightRef(pc.p.light).l;
  Uints masks = Uints(pc.p.masks);
  AfsmListedRef listed = AfsmListedRef(pc.p.listed);
  int count = 0;
  float lost = 0.0f;
  bool bound = false;
  GpuViewSample s;
  bool split = state.v[2u * i + 1u] != kAfsmMiss;
  for (uint e = 0u; e < 2u; ++e) {
    uint pos = state.v[2u * i + e];
    if (pos == kAfsmUncovered) {
      // No list holds it: its rays decide (alias_free.cpp trace_unlisted), a split sample's entry
      // toward the light samples on its side (e 0: the front, as afsm_soft_list_scatter's).
      if (!bound) {
        s = ViewSamplesIn(pc.p.samples).v[i];
        scene_bind(pc.p.scene);
        bound = true;
      }
      vec3 n_unit = offset_normal(s.ng);
      for (uint k = 0u; k < light.n; ++k) {
        vec3 q = afsm_point(pc.p.light, light.n, k);
        if (split && leaves_front(n_unit, q - s.p) != (e == 0u)) continue;
        vec3 org, dir;
        float tfar;
        shadow_segment(s.p, s.ng, q, org, dir, tfar);
        lost += 1.0f - trace_transmittance(org, dir, tfar);
      }
      continue;
    }
    if (pos >= kAfsmUncovered) continue;
    for (uint w = 0u; w < light.words; ++w) {
      uint blocked = masks.v[pos * light.stride + w];
      count += bitCount(blocked);
      if (light.stride == light.words) continue;
      for (uint rest = masks.v[pos * light.stride + light.words + w] & ~blocked; rest != 0u; rest &= rest - 1u) {
        if (!bound) {
          s = ViewSamplesIn(pc.p.samples).v[i];
          scene_bind(pc.p.scene);
          bound = true;
        }
        vec3 org, dir;
        float tfar;
        shadow_segment(s.p, s.ng, afsm_point(pc.p.light, light.n, 32u * w + uint(findLSB(rest))), org, dir, tfar);
        lost += 1.0f - trace_transmittance(org, dir, tfar);
      }
    }
    count -= int(listed.v[pos].ignored);
  }
  float inv = 1.0f / float(light.n);
  visibility.v[i] = max(0.0f, 1.0f - (float(count) + lost) * inv);
}
