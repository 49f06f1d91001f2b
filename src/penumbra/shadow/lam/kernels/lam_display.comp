#version 460
// `lam`'s display on the GPU (agrawala2000 §4, Display; attenuation_map.cpp visibility): one thread
// per view-sample slot, its point projected into the LDI and looked up (1 or 4 texels, the layer
// within epsilon of its depth), on a closed object clamped by the light's area in front of its
// plane: lam_shared.h lam_sample_visibility, the CPU's function. agrawala2000 §4: the paper uses
// hardware texturing for the display; here a compute kernel reads the layers (the same lookup for
// every view sample, whatever its depth complexity).
// A point the texels do not resolve (kLamUnresolved, with the view's `unresolved` on) is traced
// here, as lam.cpp traces it: the fraction of the LDI's light points it sees through the scene's
// BVH, a light point behind a closed surface's own plane counting as blocked. Those threads run
// N rays while their subgroup's other threads may be done (what that divergence costs on a GPU is
// for issue 31's next measurement: the `lam-paper-display` step of gpu-bench.sh times the lookup
// alone beside the suite's default).
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/gpu/scene_access.glsl"
#include "penumbra/shadow/lam/lam_kernels_shared.h"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { LamDisplayParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer MapViewRef { LamMapView m; };
layout(buffer_reference, scalar) buffer CountersRef { LamCounters c; };

// lam.cpp trace_unresolved for one view sample: V over the LDI's n light points.
float lam_traced_visibility(GpuViewSample s, bool closed, inout uint rays) {
  uint n = pc.p.point_count;
  float eps = ray_offset_epsilon(s.p);
  vec3 n_unit = offset_normal(s.ng);
  float lit = 0.0f;
  for (uint k = 0u; k < n; ++k) {
    vec3 d = Vec3s(pc.p.points).v[k] - s.p;
    if (closed && dot(d, s.ng) <= 0.0f) continue;  // behind the solid's own plane: blocked
    vec3 org, dir;
    fan_segment(s.p, n_unit, eps, d, org, dir);
    lit += trace_transmittance(org, dir, kFanTfar);
    rays += 1u;
  }
  return n > 0u ? lit / float(n) : 0.0f;
}

void main() {
  uint i = pn_thread_index();
  uint texels = 0u;
  uint traced = 0u;
  uint rays = 0u;
  if (i < pc.p.slots) {
    GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
    if (s.object != kMissObject) {
      scene_bind(pc.p.scene);
      bool closed = (g_objects.v[s.object].flags & kObjectClosed) != 0u;
      LamMapView m = MapViewRef(pc.p.view).m;
      float v = lam_sample_visibility(Floats(pc.p.layers), Uints(pc.p.ranges), 2u, Floats(pc.p.outline), m, s.p,
                                      s.ng, closed, pc.p.bilinear != 0u, texels);
      if (v == kLamUnresolved) {
        v = lam_traced_visibility(s, closed, rays);
        traced = 1u;
      }
      Floats(pc.p.visibility).v[i] = v;
    }
  }
  texels = subgroupAdd(texels);
  traced = subgroupAdd(traced);
  rays = subgroupAdd(rays);
  if (subgroupElect()) {
    if (texels > 0u) atomicAdd(CountersRef(pc.p.counters).c.texels, uint64_t(texels));
    if (traced > 0u) {
      atomicAdd(CountersRef(pc.p.counters).c.traced, uint64_t(traced));
      atomicAdd(CountersRef(pc.p.counters).c.rays, uint64_t(rays));
    }
  }
}
