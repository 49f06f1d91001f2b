#version 460
// gpu/ray_queries.h trace_closest: one thread per ray.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/gpu/ray_queries_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RayQueryParams p; } pc;
layout(buffer_reference, scalar) readonly buffer RaysIn { GpuRay v[]; };
layout(buffer_reference, scalar) writeonly buffer HitsOut { GpuRayHit v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.count) return;
  scene_bind(pc.p.scene);
  GpuRay r = RaysIn(pc.p.rays).v[i];
  RayHit hit;
  trace_closest(r.org, r.dir, r.tfar, hit);
  GpuRayHit h;
  h.t = hit.t;
  h.object = hit.object;
  h.prim = hit.prim;
  // Barycentrics of the world mesh, as Embree reports them (a mirroring instance swaps them).
  h.u = hit.mirrored ? hit.v : hit.u;
  h.v = hit.mirrored ? hit.u : hit.v;
  HitsOut(pc.p.results).v[i] = h;
}
