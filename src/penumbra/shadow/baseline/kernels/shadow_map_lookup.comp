#version 460
// `shadow-map` on the GPU (shadow/baseline/shadow_map.cpp): one thread per view-sample slot, the
// hard lookup or PCF of shadow/shadow_map_shared.h's shadow_map_visibility, the CPU's function.
// Texels read and receivers outside the map are counted per subgroup, then one atomic.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/scene_access.glsl"
#include "penumbra/shadow/shadow_map_kernels_shared.h"
#include "penumbra/shadow/view_samples_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { ShadowMapLookupParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer BlockRef { ShadowMapBlock b; };
layout(buffer_reference, scalar) buffer CountersRef { GpuShadowMapCounters c; };

void main() {
  uint i = pn_thread_index();
  uint texels = 0u, outside = 0u;
  if (i < pc.p.io.slots) {
    GpuViewSample s = ViewSamplesIn(pc.p.io.samples).v[i];
    if (s.object != kMissObject) {
      float v = 0.0f;
      if (pc.p.io.has_map != 0u) {
        scene_bind(pc.p.io.scene);
        ShadowMapBlock block = BlockRef(pc.p.io.block).b;
        bool closed = (g_objects.v[s.object].flags & kObjectClosed) != 0u;
        v = shadow_map_visibility(Floats(pc.p.io.z), Floats(pc.p.io.opacity), block.map, block.bias, pc.p.pcf,
                                  pc.p.bilinear != 0u,
                                  pc.p.light_center, pc.p.light_n, s.p, s.ng, closed, texels);
        if (sm_in_front_of_light(pc.p.light_center, pc.p.light_n, s.p) && sm_outside(block.map, s.p)) outside = 1u;
      }
      Floats(pc.p.io.visibility).v[i] = v;
    }
  }
  texels = subgroupAdd(texels);
  outside = subgroupAdd(outside);
  if (subgroupElect() && (texels > 0u || outside > 0u)) {
    CountersRef c = CountersRef(pc.p.io.counters);
    atomicAdd(c.c.texels, uint64_t(texels));
    atomicAdd(c.c.outside, outside);
  }
}
