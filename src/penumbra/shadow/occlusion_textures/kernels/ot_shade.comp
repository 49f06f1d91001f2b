#version 460
// `occlusion-textures` on the GPU (occlusion_textures.cpp shade): one thread per view-sample
// slot, occlusion_shared.h's ot_visibility, the CPU's function: the slices above the point, its
// kernel on each (eq. 4), one prefiltered lookup each (trilinear mipmap, N-buffer or summed-area
// table, §3.2), combined by eq. 5, times the horizon of a closed receiver (ot_horizon; none left:
// 0 without lookups), or for an open receiver times its own slice's test (ot_own_slice); then, where
// it is lit, the near field's ray toward the light's centre through the BVH (ot_near_field_length,
// trace/ray_shared.h shadow_segment: the CPU's segment, which Embree traces there), whose depth
// the slices and the own slice leave out. Lookups, texels read, kernels outside the texture,
// elongated kernels and near fields traced are counted per subgroup, then one atomic each.
// eisemann2006 §3.2: the paper's lookups are the texture units' trilinear (anisotropic) filtering
// of mipmapped RGBA8 textures and fragment-shader reads of N-buffers; here a compute thread
// reads the bytes and blends them with the CPU's arithmetic.
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/shadow/occlusion_textures/occlusion_kernels_shared.h"
#include "penumbra/shadow/occlusion_textures/occlusion_shared.h"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { OtShadeParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer SetupRef { OtSetup s; };
layout(buffer_reference, scalar) buffer CountersRef { OtShadeCounters c; };

void main() {
  uint i = pn_thread_index();
  OtCounters n;
  n.lookups = 0u;
  n.reads = 0u;
  n.outside = 0u;
  n.strips = 0u;
  uint near_rays = 0u;
  if (i < pc.p.slots) {
    GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
    if (s.object != kMissObject) {
      OtTextures t;
      t.prefilter = pc.p.prefilter;
      t.sat_counts = pc.p.sat_counts;
      t.width = pc.p.width;
      t.height = pc.p.height;
      t.slices = SetupRef(pc.p.setup).s.slices;
      t.levels = pc.p.levels;
      t.bytes = Bytes(pc.p.textures);
      t.sat_u = Uints(pc.p.textures);
      t.sat_d = Doubles(pc.p.textures);
      t.sat = pc.p.sat;
      scene_bind(pc.p.scene);
      bool closed = (g_objects.v[s.object].flags & kObjectClosed) != 0u;
      OtSetup setup = SetupRef(pc.p.setup).s;
      float horizon = ot_horizon(setup, s.p, s.ng, closed);
      float near = ot_near_field_length(setup, s.p, s.ng, closed);
      float near_z = ot_near_field_depth(setup, s.p, near);
      float v = 0.0f;
      // The tiles' slices follow the set-up in its buffer (occlusion_shared.h OtSetup).
      Floats tiles = Floats(pc.p.setup + uint64_t(kOtSetupBytes));
      if (horizon > 0.0f) v = ot_visibility(setup, tiles, t, Floats(pc.p.bounds), s.p, !closed, near_z, n) * horizon;
      // An open receiver's own slice (penumbra's addition; the CPU's shade does the same).
      if (v > 0.0f && !closed && pc.p.nearest != 0ul)
        v *= ot_own_slice(setup, tiles, Floats(pc.p.nearest), pc.p.nearest_scale, s.p, s.ng, near_z);
      if (v > 0.0f && near > 0.0f) {
        vec3 org, dir;
        float tfar;
        shadow_segment(s.p, s.ng, setup.center, org, dir, tfar);
        v *= trace_transmittance(org, dir, min(near, tfar));
        near_rays = 1u;
      }
      Floats(pc.p.visibility).v[i] = v;
    }
  }
  uint lookups = subgroupAdd(n.lookups), reads = subgroupAdd(n.reads);
  uint outside = subgroupAdd(n.outside), strips = subgroupAdd(n.strips);
  near_rays = subgroupAdd(near_rays);
  if (subgroupElect() && (lookups > 0u || near_rays > 0u)) {
    CountersRef c = CountersRef(pc.p.counters);
    atomicAdd(c.c.lookups, uint64_t(lookups));
    atomicAdd(c.c.reads, uint64_t(reads));
    atomicAdd(c.c.outside, uint64_t(outside));
    atomicAdd(c.c.strips, uint64_t(strips));
    atomicAdd(c.c.near_rays, uint64_t(near_rays));
  }
}
