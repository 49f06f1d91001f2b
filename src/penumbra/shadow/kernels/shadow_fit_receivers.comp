#version 460
// The fit of a light view to its receivers, on the device (raster/shadow_view.h: reduce_receivers;
// shadow_map_common.h receiver_points): one thread per view-sample slot. A hit in front of the
// light is a receiver; those beyond min_near reduce to the extremes of x/z, y/z and z
// (raster/shadow_view_shared.h shadow_view_project), kept as atomic min and max of their ordered
// bits (raster_order_bits): the very floats the CPU's min and max give, whatever the order. The
// host reads the 32 bytes back and builds the view (build_shadow_view).
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/raster/raster_shared.h"
#include "penumbra/shadow/shadow_map_kernels_shared.h"
#include "penumbra/shadow/view_samples_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { FitReceiversParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) buffer RangeRef { GpuReceiverRange r; };

void main() {
  uint i = pn_thread_index();
  // Each thread's contribution (the identities where it has none), reduced over the subgroup
  // first: one set of atomics per subgroup.
  uint receiver = 0u, fitted = 0u;
  uint x0 = 0xffffffffu, x1 = 0u, y0 = 0xffffffffu, y1 = 0u, z0 = 0xffffffffu, z1 = 0u;
  if (i < pc.p.slots) {
    GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
    if (s.object != kMissObject && sm_in_front_of_light(pc.p.light_center, pc.p.light_n, s.p)) {
      receiver = 1u;
      float x, y, z;
      if (shadow_view_project(pc.p.axes, s.p, x, y, z)) {
        fitted = 1u;
        x0 = x1 = raster_order_bits(x);
        y0 = y1 = raster_order_bits(y);
        z0 = z1 = raster_order_bits(z);
      }
    }
  }
  receiver = subgroupAdd(receiver);
  fitted = subgroupAdd(fitted);
  x0 = subgroupMin(x0);
  x1 = subgroupMax(x1);
  y0 = subgroupMin(y0);
  y1 = subgroupMax(y1);
  z0 = subgroupMin(z0);
  z1 = subgroupMax(z1);
  if (!subgroupElect() || receiver == 0u) return;
  RangeRef range = RangeRef(pc.p.range);
  atomicAdd(range.r.receivers, receiver);
  if (fitted == 0u) return;
  atomicAdd(range.r.fitted, fitted);
  atomicMin(range.r.x0, x0);
  atomicMax(range.r.x1, x1);
  atomicMin(range.r.y0, y0);
  atomicMax(range.r.y1, y1);
  atomicMin(range.r.z0, z0);
  atomicMax(range.r.z1, z1);
}
