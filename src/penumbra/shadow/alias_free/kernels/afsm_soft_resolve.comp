#version 460
// afsm on the GPU (alias_free.cpp AliasFreeSoft::evaluate, "resolve"): V per view-sample slot,
// 1 - (blocked light samples over its list entries, less the preset other side of a split
// sample) / N. Entries outside the fitted view count as lit.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/alias_free/kernels/afsm_soft_access.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmSoftParams p; } pc;

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
  for (uint e = 0u; e < 2u; ++e) {
    uint pos = state.v[2u * i + e];
    if (pos >= kAfsmUncovered) continue;
    for (uint w = 0u; w < light.words; ++w) count += bitCount(masks.v[pos * light.words + w]);
    count -= int(listed.v[pos].ignored);
  }
  float inv = 1.0f / float(light.n);
  visibility.v[i] = 1.0f - float(count) * inv;
}
