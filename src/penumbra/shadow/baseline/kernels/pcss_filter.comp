#version 460
// `pcss` on the GPU (shadow/baseline/pcss.cpp): one thread per view-sample slot, the blocker
// search, penumbra estimate and filter (Fernando 2005) or xie2007 §3's filter of
// shadow/shadow_map_shared.h's pcss_visibility, the CPU's function, with the CPU's kernels
// (LightSampleSet base points, uploaded) rotated by the CPU's per-pixel shift (Rng(key, 0x5050,
// pixel)). Texels read, receivers outside the map and samples without blockers are counted per
// subgroup, then one atomic each.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/scene_access.glsl"
#include "penumbra/gpu/light_access.glsl"
#include "penumbra/core/rng_shared.h"
#include "penumbra/shadow/shadow_map_kernels_shared.h"
#include "penumbra/shadow/view_samples_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { PcssFilterParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer BlockRef { ShadowMapBlock b; };
layout(buffer_reference, scalar) buffer CountersRef { GpuShadowMapCounters c; };

void main() {
  uint i = pn_thread_index();
  uint texels = 0u, outside = 0u, unblocked = 0u;
  if (i < pc.p.io.slots) {
    GpuViewSample s = ViewSamplesIn(pc.p.io.samples).v[i];
    if (s.object != kMissObject) {
      float v = 0.0f;
      if (pc.p.io.has_map != 0u) {
        scene_bind(pc.p.io.scene);
        ShadowMapBlock block = BlockRef(pc.p.io.block).b;
        GpuLight light = LightRef(pc.p.light).v;
        PcssLight L;
        L.geometry = light.geometry;
        L.textured = light.textured;
        L.table_width = light.table_width;
        L.table_height = light.table_height;
        L.extent_radius = pc.p.extent_radius;
        bool closed = (g_objects.v[s.object].flags & kObjectClosed) != 0u;
        vec2 shift = vec2(0.0f);
        if (pc.p.jitter != 0u) {
          RngState rng = rng_keyed(pc.p.key, 0x5050UL, uint64_t(s.pixel), 0UL);
          shift = rng_next_2d(rng);
        }
        bool no_blocker;
        v = pcss_visibility(Floats(pc.p.io.z), Floats(pc.p.io.opacity), block.map, block.bias, L, Floats(light.marginal),
                            Floats(light.conditional), Floats(pc.p.blocker_base), pc.p.blocker_samples,
                            Floats(pc.p.pcf_base), pc.p.pcf_samples, pc.p.xie2007, shift, s.p, s.ng, closed, texels,
                            no_blocker);
        if (no_blocker) unblocked = 1u;
        if (sm_in_front_of_light(L.geometry.center, L.geometry.n, s.p) && sm_outside(block.map, s.p)) outside = 1u;
      }
      Floats(pc.p.io.visibility).v[i] = v;
    }
  }
  texels = subgroupAdd(texels);
  outside = subgroupAdd(outside);
  unblocked = subgroupAdd(unblocked);
  if (subgroupElect() && (texels > 0u || outside > 0u || unblocked > 0u)) {
    CountersRef c = CountersRef(pc.p.io.counters);
    atomicAdd(c.c.texels, uint64_t(texels));
    atomicAdd(c.c.outside, outside);
    atomicAdd(c.c.no_blocker, unblocked);
  }
}
