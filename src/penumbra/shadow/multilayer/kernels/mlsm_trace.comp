#version 460
// `mlsm` on the GPU (multilayer_kernels_shared.h): one thread per view-sample slot traces its
// light samples through the k-layer map (xie2007 §4.3): multilayer_trace_shared.h's
// ml_trace_opaque, the CPU's set-up, walk and leaf test, over the GPU's map and pyramid.
#include "penumbra/shadow/multilayer/kernels/multilayer_trace_common.glsl"

float trace_ray(MlTraceBlock b, DepthPyramidRef pyr, vec3 p, vec3 ng, bool closed, vec3 q, inout MlTraceCounters c) {
  MlOpaqueMapRef m;
  m.counts = pc.p.map_a;
  m.samples = pc.p.map_b;
  m.width = b.width;
  m.k = b.k;
  return ml_trace_opaque(b.view, b.setup, pyr, m, p, ng, closed, q, c);
}

// Every caster is opaque to mlsm: anything in the near field blocks.
float combine_near(float t_map, float t_near) { return t_near < 1.0f ? 0.0f : t_map; }

#include "penumbra/shadow/multilayer/kernels/multilayer_trace.glsl"
