#version 460
// afsm on the GPU, sintorn2008 §3.1 with issue 33's sides (alias_free.cpp AliasFreeSoft::evaluate,
// "sides" and the lists' counts): one thread per view-sample slot, up to two list entries each.
// A sample on a closed mesh is listed outward; on an open surface whose plane leaves every light
// sample on one side, on that side; where its plane cuts the light samples (a two-sided leaf lit
// partly from behind), once per side (the split of the CPU version). Each entry's texel is kept
// and its depth counted in the slabs' histogram (afsm_soft_slabs cuts the slabs from it).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/shadow/alias_free/kernels/afsm_soft_access.glsl"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmSoftParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.count) return;
  GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
  Uints state = Uints(pc.p.state);
  state.v[2u * i + 1u] = kAfsmMiss;
  if (s.object == kMissObject) {
    state.v[2u * i] = kAfsmMiss;
    return;
  }
  AfsmSoftLight light = AfsmLightRef(pc.p.light).l;
  if (!(dot(s.p - light.c, light.axis) > 0.0f)) {
    state.v[2u * i] = kAfsmNotListed;  // sees no light sample: V = 0
    return;
  }
  scene_bind(pc.p.scene);
  bool front = true, back = false;
  if ((g_objects.v[s.object].flags & kObjectClosed) == 0u) {
    // (The disk test does not depend on the pattern.)
    int disk = afsm_side_of_disk(afsm_line_g(s.ng, light.ls, light.lt), afsm_line_h(s.ng, light.c - s.p),
                                 light.max_distance2);
    if (disk != 0) {
      front = disk > 0;
      back = !front;
    } else {
      // Each light point's side, as its shadow ray decides it (ray_shared.h leaves_front).
      vec3 n_unit = offset_normal(s.ng);
      uint in_front = 0u;
      for (uint k = 0u; k < light.n; ++k)
        if (leaves_front(n_unit, afsm_point(pc.p.light, light.n, k) - s.p)) ++in_front;
      front = in_front > 0u;
      back = in_front < light.n;
    }
  }
  RasterView view = RasterViewRef(pc.p.view).v;
  Vec3s points = Vec3s(pc.p.points);
  uint entry = 2u * i;
  for (int side = 0; side < 2; ++side) {
    bool f = side == 0;
    if (f ? !front : !back) continue;
    vec3 q = offset_ray_origin_shared(s.p, s.ng, f ? s.ng : -s.ng);
    points.v[entry] = q;
    vec4 h = raster_project(view, q);
    float x = h.x / h.w, y = h.y / h.w;
    if (h.z >= view.near && x >= 0.0f && y >= 0.0f && x < float(view.width) && y < float(view.height)) {
      uint texel = uint(int(y)) * uint(view.width) + uint(int(x));
      state.v[entry] = texel;
      atomicAdd(afsm_slabs(pc.p.view).s.slab_of_bin[afsm_depth_bin(view.near, view.far, h.z)], 1u);
    } else {
      state.v[entry] = kAfsmUncovered;  // not listed: lit, as outside a shadow map
    }
    ++entry;
  }
}
