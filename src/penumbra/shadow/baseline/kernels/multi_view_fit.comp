#version 460
// `multi-view-sm`'s fit on the device (multi_view_shadow_map.cpp: light_view_from per light point,
// raster/shadow_view.h reduce_receivers): one thread per view-sample slot. A hit in front of the
// light is a receiver of every view; per view, those beyond min_near reduce to the extremes of
// x/z, y/z and z in that view's frame (shadow_view_project), as atomic min and max of their
// ordered bits: the very floats the CPU's min and max give. The host reads the ranges back and
// builds each view (build_shadow_view), as for `shadow-map` (shadow/kernels/shadow_fit_receivers.comp).
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/raster/raster_shared.h"
#include "penumbra/shadow/baseline/multi_view_shared.h"
#include "penumbra/shadow/shadow_map_kernels_shared.h"
#include "penumbra/shadow/view_samples_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { MultiViewFitParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) buffer Ranges { GpuReceiverRange r[]; };

void main() {
  uint i = pn_thread_index();
  bool receiver = false;
  vec3 p = vec3(0.0f);
  if (i < pc.p.slots) {
    GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
    receiver = s.object != kMissObject && sm_in_front_of_light(pc.p.light_center, pc.p.light_n, s.p);
    p = s.p;
  }
  uint receivers = subgroupAdd(receiver ? 1u : 0u);
  if (receivers == 0u) return;  // the whole subgroup: nothing to add to any view
  Ranges ranges = Ranges(pc.p.ranges);
  Vec3s eyes = Vec3s(pc.p.eyes);
  ShadowViewAxes axes = pc.p.axes;
  for (uint view = 0u; view < pc.p.views; ++view) {
    // Each thread's contribution (the identities where it has none), reduced over the subgroup
    // first: one set of atomics per subgroup and view.
    uint fitted = 0u;
    uint x0 = 0xffffffffu, x1 = 0u, y0 = 0xffffffffu, y1 = 0u, z0 = 0xffffffffu, z1 = 0u;
    axes.eye = eyes.v[view];
    float x, y, z;
    if (receiver && shadow_view_project(axes, p, x, y, z)) {
      fitted = 1u;
      x0 = x1 = raster_order_bits(x);
      y0 = y1 = raster_order_bits(y);
      z0 = z1 = raster_order_bits(z);
    }
    fitted = subgroupAdd(fitted);
    x0 = subgroupMin(x0);
    x1 = subgroupMax(x1);
    y0 = subgroupMin(y0);
    y1 = subgroupMax(y1);
    z0 = subgroupMin(z0);
    z1 = subgroupMax(z1);
    // No `continue` before the next view's subgroup operations: the whole subgroup takes them.
    if (subgroupElect()) {
      atomicAdd(ranges.r[view].receivers, receivers);
      if (fitted > 0u) {
        atomicAdd(ranges.r[view].fitted, fitted);
        atomicMin(ranges.r[view].x0, x0);
        atomicMax(ranges.r[view].x1, x1);
        atomicMin(ranges.r[view].y0, y0);
        atomicMax(ranges.r[view].y1, y1);
        atomicMin(ranges.r[view].z0, z0);
        atomicMax(ranges.r[view].z1, z1);
      }
    }
  }
}
