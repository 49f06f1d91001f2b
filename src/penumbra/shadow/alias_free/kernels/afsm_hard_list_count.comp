#version 460
// afsm-hard on the GPU, sintorn2008 §3.1 (alias_free.cpp AliasFreeHard::evaluate and
// texel_lists.cpp build_texel_lists, pass 1 and the counts of pass 2): one thread per view-sample
// slot. A visible sample in front of the light (on a closed mesh also facing the light's centre)
// is listed at its shadow ray's origin: outward on a closed mesh, on the centre's side of an open
// surface (§3.3 in receiver form, as the CPU). Its texel in the fitted view is counted; samples
// outside the view (or before its near plane) are uncovered and lit, as on the CPU.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/shadow/alias_free/alias_free_shared.h"
#include "penumbra/shadow/view_samples_shared.h"
#include "penumbra/trace/ray_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmHardParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.count) return;
  GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
  Uints state = Uints(pc.p.state);
  if (s.object == kMissObject) {
    state.v[i] = kAfsmMiss;
    return;
  }
  scene_bind(pc.p.scene);
  vec3 c = pc.p.light_center;
  bool closed = (g_objects.v[s.object].flags & kObjectClosed) != 0u;
  if (!(dot(s.p - c, pc.p.light_n) > 0.0f) || (closed && !(dot(s.ng, c - s.p) > 0.0f))) {
    state.v[i] = kAfsmNotListed;
    return;
  }
  vec3 q = offset_ray_origin_shared(s.p, s.ng, closed ? s.ng : c - s.p);
  Vec3s(pc.p.points).v[i] = q;
  RasterView view = RasterViewRef(pc.p.view).v;
  vec4 h = raster_project(view, q);
  float x = h.x / h.w, y = h.y / h.w;
  bool in_view = h.z >= view.near && x >= 0.0f && y >= 0.0f && x < float(view.width) && y < float(view.height);
  if (!in_view) {
    state.v[i] = kAfsmUncovered;
    return;
  }
  uint texel = uint(int(y)) * uint(view.width) + uint(int(x));
  state.v[i] = texel;
  atomicAdd(Uints(pc.p.first).v[texel], 1u);
}
