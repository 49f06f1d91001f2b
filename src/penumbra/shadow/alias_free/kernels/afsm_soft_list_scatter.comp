#version 460
// afsm on the GPU (alias_free.cpp AliasFreeSoft::evaluate, the scatter and "init"): one thread per
// view-sample slot; each listed entry takes the next position of its key's list (its slab and
// texel: afsm_soft_list_key) and its mask starts: one side of a split sample with the other side's light samples set (ignored: not
// counted), a sample on a closed mesh with the light samples behind its own tangent plane set
// (its shadow rays toward them would start inside the object), others empty; its mask of samples
// partly covered (AfsmSoftLight::stride) empty.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/scene_access.glsl"
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
  uint e0 = state.v[2u * i], e1 = state.v[2u * i + 1u];
  if (e0 >= kAfsmNotListed) return;  // a miss, or not listed at all
  bool split = e1 != kAfsmMiss;
  GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
  scene_bind(pc.p.scene);
  bool closed = (g_objects.v[s.object].flags & kObjectClosed) != 0u;
  AfsmSoftLight light = AfsmLightRef(pc.p.light).l;
  Uints masks = Uints(pc.p.masks);
  vec3 n_unit = offset_normal(s.ng);
  vec2 g = afsm_line_g(s.ng, light.ls, light.lt);
  float h = afsm_line_h(s.ng, light.c - s.p);
  for (uint e = 0u; e < 2u; ++e) {
    uint key = state.v[2u * i + e];
    if (key >= kAfsmUncovered) continue;
    uint pos = Uints(pc.p.first).v[key] + atomicAdd(Uints(pc.p.cursor).v[key], 1u);
    bool front = e == 0u;  // a split sample's entries: front, then back
    uint ignored = 0u;
    for (uint w = 0u; w < light.words; ++w) {
      uint bits = 0u;
      for (uint b = 0u; b < 32u; ++b) {
        uint k = 32u * w + b;
        if (k >= light.n) break;
        bool preset = false;
        if (split) preset = leaves_front(n_unit, afsm_point(pc.p.light, light.n, k) - s.p) != front;
        else if (closed) preset = !afsm_above(afsm_local(pc.p.light, k).x, afsm_local(pc.p.light, k).y, g, h);
        if (preset) bits |= 1u << b;
      }
      masks.v[pos * light.stride + w] = bits;
      if (split) ignored += uint(bitCount(bits));
    }
    // The samples the casters that stop part of the light cover (where the scene has them).
    for (uint w = light.words; w < light.stride; ++w) masks.v[pos * light.stride + w] = 0u;
    AfsmSoftListed l;
    l.p = Vec3s(pc.p.points).v[2u * i + e];
    l.ignored = ignored;
    AfsmListedRef(pc.p.listed).v[pos] = l;
    state.v[2u * i + e] = pos;
  }
}
