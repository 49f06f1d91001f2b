#version 460
// `lam`'s display on the GPU (agrawala2000 §4, Display; attenuation_map.cpp visibility): one thread
// per view-sample slot, its point projected into the LDI and looked up (1 or 4 texels, the layer
// within epsilon of its depth), on a closed object clamped by the light's area in front of its
// plane: lam_shared.h lam_sample_visibility, the CPU's function. agrawala2000 §4: the paper uses
// hardware texturing for the display; here a compute kernel reads the layers (the same lookup for
// every view sample, whatever its depth complexity).
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/scene_access.glsl"
#include "penumbra/shadow/lam/lam_kernels_shared.h"
#include "penumbra/shadow/view_samples_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { LamDisplayParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer MapViewRef { LamMapView m; };
layout(buffer_reference, scalar) buffer CountersRef { LamCounters c; };

void main() {
  uint i = pn_thread_index();
  uint texels = 0u;
  if (i < pc.p.slots) {
    GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
    if (s.object != kMissObject) {
      scene_bind(pc.p.scene);
      bool closed = (g_objects.v[s.object].flags & kObjectClosed) != 0u;
      LamMapView m = MapViewRef(pc.p.view).m;
      Floats(pc.p.visibility).v[i] = lam_sample_visibility(Floats(pc.p.layers), Uints(pc.p.ranges), 2u,
                                                           Floats(pc.p.outline), m, s.p, s.ng, closed,
                                                           pc.p.bilinear != 0u, texels);
    }
  }
  texels = subgroupAdd(texels);
  if (subgroupElect() && texels > 0u) atomicAdd(CountersRef(pc.p.counters).c.texels, uint64_t(texels));
}
