#version 460
// `lam`'s "Process Attenuation Maps" on the GPU (agrawala2000 §4, Precompute line 7;
// attenuation_map.cpp Builder::build's finalize): one thread per reference texel sorts its layers
// by depth, takes attenuation = min(1, count / N) (a weighted layer's: lam_shared.h
// lam_layer_attenuation), and writes them into the flat layer array at a
// place allocated with one atomic per subgroup (the CPU lays texels out in order with a prefix sum;
// here a texel's range is (first, end) in `ranges`, and each texel's layers are the CPU's).
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/lam/lam_kernels_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { LamFinalizeParams p; } pc;
layout(buffer_reference, scalar) buffer BuildLayers { LamBuildLayer v[]; };
layout(buffer_reference, scalar) buffer CountersRef { LamCounters c; };

void main() {
  uint t = pn_thread_index();
  uint texels = pc.p.texels;
  uint n = t < texels ? Uints(pc.p.counts).v[t] : 0u;
  BuildLayers build = BuildLayers(pc.p.build);
  // Insertion sort by depth, in place (a texel has a handful of layers).
  for (uint i = 1u; i < n; ++i) {
    LamBuildLayer l = build.v[i * texels + t];
    uint j = i;
    for (; j > 0u && build.v[(j - 1u) * texels + t].z > l.z; --j) build.v[j * texels + t] = build.v[(j - 1u) * texels + t];
    build.v[j * texels + t] = l;
  }
  // Room for the subgroup's layers: one atomic, the base shared by subgroupMax (the others hold 0).
  CountersRef counters = CountersRef(pc.p.counters);
  uint total = subgroupAdd(n);
  uint base = 0u;
  if (subgroupElect() && total > 0u) base = atomicAdd(counters.c.allocated, total);
  base = subgroupMax(base);
  uint first = base + subgroupExclusiveAdd(n);
  uint deepest = subgroupMax(n);
  if (subgroupElect() && deepest > 0u) atomicMax(counters.c.max_depth, deepest);
  if (t >= texels) return;
  Uints ranges = Uints(pc.p.ranges);
  ranges.v[2u * t] = first;
  ranges.v[2u * t + 1u] = first + n;
  Floats layers = Floats(pc.p.layers);
  for (uint i = 0u; i < n; ++i) {
    LamBuildLayer l = build.v[i * texels + t];
    layers.v[2u * (first + i)] = l.z;
    layers.v[2u * (first + i) + 1u] = lam_layer_attenuation(l.count, l.peak, pc.p.inv_samples);
  }
}
