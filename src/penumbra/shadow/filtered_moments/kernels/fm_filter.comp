#version 460
// `vsm`, `evsm`, `msm` on the GPU (filtered_moments_gpu.cpp): one thread per view-sample slot,
// filtered_moments_shared.h's fm_shade, the CPU's function: the blocker search and the filter as
// two lookups of the moment map's summed-area table or mip chain, the model's estimates from the
// moments; then the near field's ray toward the light's centre through the BVH
// (fm_near_field_length, trace/ray_shared.h shadow_segment: the CPU's segment, which Embree traces
// there). Texels read, receivers outside the map, samples without blockers and near fields traced
// are counted per subgroup, then one atomic each.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/shadow/filtered_moments/filtered_moments_kernels_shared.h"
#include "penumbra/shadow/filtered_moments/filtered_moments_shared.h"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { FmFilterParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer ModelRef { FmModel m; };
layout(buffer_reference, scalar) readonly buffer ShadeRef { FmShadeBlock b; };
layout(buffer_reference, scalar) readonly buffer RangeRef { FmDepthRange r; };
layout(buffer_reference, scalar) readonly buffer MapRecordRef { FmMapRecord r; };
layout(buffer_reference, scalar) buffer CountersRef { GpuShadowMapCounters c; };

void main() {
  uint i = pn_thread_index();
  uint texels = 0u, outside = 0u, unblocked = 0u, near_rays = 0u;
  if (i < pc.p.io.slots) {
    GpuViewSample s = ViewSamplesIn(pc.p.io.samples).v[i];
    if (s.object != kMissObject) {
      float v = 0.0f;
      if (pc.p.io.has_map != 0u) {
        scene_bind(pc.p.io.scene);
        FmShadeBlock block = ShadeRef(pc.p.shade).b;
        FmModel model = ModelRef(pc.p.model).m;
        FmMapRecord record = MapRecordRef(pc.p.map).r;
        FmMapRef map;
        map.prefilter = record.prefilter;
        map.width = record.width;
        map.height = record.height;
        map.sat = Doubles(pc.p.table);
        map.sat_layout = record.sat;
        // The moments of an empty texel, as the texels store them (floats).
        FilteredChannels empty = fm_encode(model, 1.0lf);
        for (int c = 0; c < 4; ++c) map.outside.v[c] = double(float(empty.v[c]));
        map.mip = Floats(pc.p.table);
        map.mip_view = record.mip;
        map.range = RangeRef(pc.p.range).r;
        bool closed = (g_objects.v[s.object].flags & kObjectClosed) != 0u;
        FmShadeCount count;
        count.lookups = 0u;
        count.unblocked = 0u;
        v = fm_shade(map, model, block, s.p, s.ng, closed, count);
        float near = fm_near_field_length(block, s.p, s.ng, closed, v);
        if (near > 0.0f) {
          vec3 org, dir;
          float tfar;
          shadow_segment(s.p, s.ng, block.map.view.eye, org, dir, tfar);
          v *= trace_transmittance(org, dir, min(near, tfar));
          near_rays = 1u;
        }
        texels = count.lookups * 16u * uint(model.channels);
        unblocked = count.unblocked;
        if (sm_in_front_of_light(block.light.center, block.light.n, s.p) && sm_outside(block.map, s.p)) outside = 1u;
      }
      Floats(pc.p.io.visibility).v[i] = v;
    }
  }
  texels = subgroupAdd(texels);
  outside = subgroupAdd(outside);
  unblocked = subgroupAdd(unblocked);
  near_rays = subgroupAdd(near_rays);
  if (subgroupElect() && (texels > 0u || outside > 0u || unblocked > 0u || near_rays > 0u)) {
    CountersRef c = CountersRef(pc.p.io.counters);
    atomicAdd(c.c.texels, uint64_t(texels));
    atomicAdd(c.c.outside, outside);
    atomicAdd(c.c.no_blocker, unblocked);
    atomicAdd(c.c.near_rays, near_rays);
  }
}
