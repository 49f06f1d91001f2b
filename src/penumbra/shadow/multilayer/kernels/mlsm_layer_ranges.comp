#version 460
// `mlsm` on the GPU (multilayer_kernels_shared.h): one thread per texel of the k-layer map writes
// the pyramid's level 0, the texel's window-depth range over all its layers, nearest to farthest
// (xie2007 §4.3: each node holds min and max over all layers; MinMaxPyramid(LayeredDepthMap,
// Window): window depth is affine along a projected segment, the walk's contract), a full
// texel's reaching kMlBeyondFullTexel with unknown_beyond_full, and counts the map's statistics.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/multilayer/multilayer_kernels_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { MlMapParams p; } pc;
layout(buffer_reference, scalar) readonly buffer TraceBlockRef { MlTraceBlock b; };
layout(buffer_reference, scalar) buffer CountersRef { MlMapCounters c; };

void main() {
  uint i = pn_thread_index();
  uint n = 0u;
  if (i < pc.p.texels) {
    int k = TraceBlockRef(pc.p.block).b.k;
    n = Uints(pc.p.map_a).v[i];
    vec2 r = vec2(pn_inf(), -pn_inf());
    if (n > 0u) {
      Floats samples = Floats(pc.p.map_b);
      r = vec2(samples.v[i * uint(k) * 4u + 1u], samples.v[(i * uint(k) + n - 1u) * 4u + 1u]);
      // A full texel does not know what lies behind its last layer (multilayer_map.cpp).
      if (pc.p.unknown_beyond_full != 0u && n >= uint(k)) r.y = kMlBeyondFullTexel;
    }
    Vec2s(pc.p.nodes).v[i] = r;
  }
  uint covered = subgroupAdd(n > 0u ? 1u : 0u), layers = subgroupAdd(n), most = subgroupMax(n);
  if (subgroupElect() && covered > 0u) {
    CountersRef c = CountersRef(pc.p.counters);
    atomicAdd(c.c.covered, uint64_t(covered));
    atomicAdd(c.c.layers, uint64_t(layers));
    atomicMax(c.c.max_layers, most);
  }
}
