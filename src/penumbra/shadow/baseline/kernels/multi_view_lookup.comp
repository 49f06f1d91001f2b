#version 460
// `multi-view-sm` on the GPU (multi_view_shadow_map.cpp): one thread per view-sample slot, the
// hard lookup (shadow_map_shared.h sm_lookup, the CPU's function, with the method's biases) of its
// point in each map of a batch, added to V in map order as the CPU adds them; the last batch
// scales by 1 / maps. With a near field (shadow_map_shared.h sm_near_field_length), each map
// answers beyond it (mv_far_lookup) and, where it lets light through, the near field's part of the
// shadow ray (trace/ray_shared.h shadow_segment, the CPU's segment) is traced through the BVH, as
// the CPU traces it through Embree. Texels read and near fields traced are counted per subgroup,
// then one atomic each.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/shadow/baseline/multi_view_shared.h"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { MultiViewLookupParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer Maps { MultiViewMap m[]; };

void main() {
  uint i = pn_thread_index();
  uint texels = 0u, near_rays = 0u;
  if (i < pc.p.slots) {
    GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
    if (s.object != kMissObject) {
      Floats visibility = Floats(pc.p.visibility);
      float v = pc.p.first != 0u ? 0.0f : visibility.v[i];
      if (sm_in_front_of_light(pc.p.light_center, pc.p.light_n, s.p)) {
        scene_bind(pc.p.scene);
        bool closed = (g_objects.v[s.object].flags & kObjectClosed) != 0u;
        Maps maps = Maps(pc.p.maps);
        for (uint m = 0u; m < pc.p.map_count; ++m) {
          MultiViewMap map = maps.m[m];
          uint64_t offset = map.first_texel * 4UL;
          float near = mv_traced_length(map.map, s.p, pc.p.near_field, pc.p.light_width);
          float t = mv_far_lookup(Floats(pc.p.z + offset), Floats(pc.p.opacity + offset), map.map, s.p, s.ng, closed,
                                  pc.p.bias, near);
          if (t > 0.0f && near > 0.0f) {
            vec3 org, dir;
            float tfar;
            shadow_segment(s.p, s.ng, map.map.view.eye, org, dir, tfar);
            t *= trace_transmittance(org, dir, min(near, tfar));
            near_rays += 1u;
          }
          v += t;
        }
        texels = pc.p.map_count;
      }
      visibility.v[i] = v * pc.p.scale;
    }
  }
  texels = subgroupAdd(texels);
  near_rays = subgroupAdd(near_rays);
  if (subgroupElect() && texels > 0u) atomicAdd(Uint64s(pc.p.counters).v[0], uint64_t(texels));
  if (subgroupElect() && near_rays > 0u) atomicAdd(Uint64s(pc.p.counters).v[1], uint64_t(near_rays));
}
