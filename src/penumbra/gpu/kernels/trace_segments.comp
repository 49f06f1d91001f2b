#version 460
// gpu/ray_queries.h trace_transmittance: one thread per segment.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/bvh_traverse.glsl"
#include "penumbra/gpu/ray_queries_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RayQueryParams p; } pc;
layout(buffer_reference, scalar) readonly buffer RaysIn { GpuRay v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.count) return;
  scene_bind(pc.p.scene);
  GpuRay r = RaysIn(pc.p.rays).v[i];
  // tnear is 0 for every shadow ray penumbra traces: start the segment there.
  vec3 org = r.org + r.dir * r.tnear;
  Floats(pc.p.results).v[i] = trace_transmittance(org, r.dir, r.tfar - r.tnear);
}
