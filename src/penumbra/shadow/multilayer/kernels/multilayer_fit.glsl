// What the multilayer fit kernels share (multilayer_kernels_shared.h): the view samples, and the
// reduction of points' view-frame coordinates to a GpuReceiverRange (x/z, y/z and z as
// raster_order_bits, atomic min and max: the very floats the CPU's min and max give, whatever the
// order), per subgroup first.
#ifndef PENUMBRA_SHADOW_MULTILAYER_KERNELS_MULTILAYER_FIT_GLSL
#define PENUMBRA_SHADOW_MULTILAYER_KERNELS_MULTILAYER_FIT_GLSL

#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/raster/raster_shared.h"
#include "penumbra/shadow/multilayer/multilayer_kernels_shared.h"
#include "penumbra/shadow/multilayer/multilayer_view_shared.h"
#include "penumbra/shadow/shadow_map_kernels_shared.h"
#include "penumbra/shadow/view_samples_shared.h"

layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer FitBlockRef { MlFitBlock b; };
layout(buffer_reference, scalar) buffer RangesRef { GpuReceiverRange r[]; };

// A thread's part of a range: the extremes of the points it added.
struct RangePart {
  uint x0, x1, y0, y1, z0, z1;
  uint points;
};

RangePart range_part_empty() {
  RangePart r;
  r.x0 = 0xffffffffu;
  r.x1 = 0u;
  r.y0 = 0xffffffffu;
  r.y1 = 0u;
  r.z0 = 0xffffffffu;
  r.z1 = 0u;
  r.points = 0u;
  return r;
}

// Adds p as the fit sees it in the view frame `axes` (shadow_view_project: ignored nearer than
// min_near).
void range_part_add(inout RangePart r, ShadowViewAxes axes, vec3 p) {
  float x, y, z;
  if (!shadow_view_project(axes, p, x, y, z)) return;
  r.x0 = min(r.x0, raster_order_bits(x));
  r.x1 = max(r.x1, raster_order_bits(x));
  r.y0 = min(r.y0, raster_order_bits(y));
  r.y1 = max(r.y1, raster_order_bits(y));
  r.z0 = min(r.z0, raster_order_bits(z));
  r.z1 = max(r.z1, raster_order_bits(z));
  r.points += 1u;
}

// Every thread of the subgroup calls this (uniform control flow): the parts reduced over the
// subgroup, then one set of atomics. `receivers`: this thread's receivers counted.
void range_reduce(RangesRef ranges, uint index, RangePart r, uint receivers) {
  receivers = subgroupAdd(receivers);
  uint points = subgroupAdd(r.points);
  uint x0 = subgroupMin(r.x0), x1 = subgroupMax(r.x1);
  uint y0 = subgroupMin(r.y0), y1 = subgroupMax(r.y1);
  uint z0 = subgroupMin(r.z0), z1 = subgroupMax(r.z1);
  if (!subgroupElect()) return;
  if (receivers > 0u) atomicAdd(ranges.r[index].receivers, receivers);
  if (points == 0u) return;
  atomicAdd(ranges.r[index].fitted, points);
  atomicMin(ranges.r[index].x0, x0);
  atomicMax(ranges.r[index].x1, x1);
  atomicMin(ranges.r[index].y0, y0);
  atomicMax(ranges.r[index].y1, y1);
  atomicMin(ranges.r[index].z0, z0);
  atomicMax(ranges.r[index].z1, z1);
}

// Slot i's view sample as a receiver of the light: false for a miss or a point behind the light.
bool fit_receiver(uint64_t samples, uint slots, uint i, vec3 light_center, vec3 light_n, out vec3 p) {
  p = vec3(0.0f);
  if (i >= slots) return false;
  GpuViewSample s = ViewSamplesIn(samples).v[i];
  p = s.p;
  return s.object != kMissObject && ml_is_receiver(light_center, light_n, s.p);
}

#endif
