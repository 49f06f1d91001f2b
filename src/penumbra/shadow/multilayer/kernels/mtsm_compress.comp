#version 460
// `mtsm` on the GPU (multilayer_kernels_shared.h): one thread per texel compresses its sorted
// fragment list into transparent layers (xie2007 §5.1: multilayer_layers_shared.h's
// ml_compress_fragments, the CPU's), written at the list's own offset (a texel never has more
// layers than fragments), and writes the pyramid's level 0: the window depths of its first
// layer's first sample and its last layer's control vertex (or kMlBeyondFullTexel where the
// compression dropped fragments behind it, with unknown_beyond_full). The map's smallest linear depth
// (z_min) and statistics are counted.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/raster/depth_image_walk_shared.h"
#include "penumbra/shadow/multilayer/multilayer_kernels_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { MlMapParams p; } pc;
layout(buffer_reference, scalar) readonly buffer TraceBlockRef { MlTraceBlock b; };
layout(buffer_reference, scalar) buffer CountersRef { MlMapCounters c; };

void main() {
  uint i = pn_thread_index();
  uint n = 0u;
  uint z_bits = 0xffffffffu;
  if (i < pc.p.texels) {
    Uints offsets = Uints(pc.p.map_a);
    uint first = offsets.v[i], end = offsets.v[i + 1u];
    MlCompression o;
    o.error = pc.p.error;
    o.resets = pc.p.resets;
    o.zero = pc.p.zero;
    MlLayersOut layers = MlLayersOut(pc.p.map_d);
    bool truncated = false;
    if (end > first)
      n = ml_compress_fragments(MlFragmentsRef(pc.p.map_b), first, end - first, o, layers, first, truncated);
    Uints(pc.p.map_c).v[i] = n;
    vec2 r = vec2(pn_inf(), -pn_inf());
    if (n > 0u) {
      RasterView view = TraceBlockRef(pc.p.block).b.view;
      float lo = layers.v[first].z_first;
      r = vec2(view_window_depth(view, lo), view_window_depth(view, layers.v[first + n - 1u].z));
      // Fragments behind the last layer dropped: unknown there (kMlBeyondFullTexel).
      if (pc.p.unknown_beyond_full != 0u && truncated) r.y = kMlBeyondFullTexel;
      z_bits = raster_order_bits(lo);
    }
    Vec2s(pc.p.nodes).v[i] = r;
  }
  uint covered = subgroupAdd(n > 0u ? 1u : 0u), count = subgroupAdd(n), most = subgroupMax(n);
  z_bits = subgroupMin(z_bits);
  if (subgroupElect() && covered > 0u) {
    CountersRef c = CountersRef(pc.p.counters);
    atomicAdd(c.c.covered, uint64_t(covered));
    atomicAdd(c.c.layers, uint64_t(count));
    atomicMax(c.c.max_layers, most);
    atomicMin(c.c.z_min_bits, z_bits);
  }
}
