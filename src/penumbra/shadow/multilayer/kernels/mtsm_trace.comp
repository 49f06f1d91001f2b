#version 460
// `mtsm` on the GPU (multilayer_kernels_shared.h): one thread per view-sample slot traces its
// light samples through the transparent map (xie2007 §5.2): multilayer_trace_shared.h's
// ml_trace_transparent, the CPU's set-up, walk and leaf test, over the GPU's layers and pyramid.
#include "penumbra/shadow/multilayer/kernels/multilayer_trace_common.glsl"

float trace_ray(MlTraceBlock b, DepthPyramidRef pyr, vec3 p, vec3 ng, bool closed, vec3 q, inout MlTraceCounters c) {
  MlTransparentMapRef m;
  m.offsets = pc.p.map_a;
  m.counts = pc.p.map_b;
  m.layers = pc.p.map_c;
  m.width = b.width;
  return ml_trace_transparent(b.view, b.setup, pyr, m, p, ng, closed, q, c);
}

// The near field's transmittance times the map's, blocked below stop_below (multilayer.cpp).
float combine_near(float t_map, float t_near) {
  float t = t_map * t_near;
  return t < TraceBlockRef(pc.p.block).b.setup.stop_below ? 0.0f : t;
}

#include "penumbra/shadow/multilayer/kernels/multilayer_trace.glsl"
