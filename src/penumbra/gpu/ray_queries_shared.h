// The records of gpu/ray_queries.h's kernels (trace_segments.comp, trace_closest_rays.comp), in
// the common subset of C++ and GLSL. 32 bytes a ray: bytes 0-11 org, 12-15 tnear, 16-27 dir,
// 28-31 tfar (trace/ray_tracer.h ShadowRay's layout); 20 bytes a hit: t, object, prim, u, v.
#ifndef PENUMBRA_GPU_RAY_QUERIES_SHARED_H
#define PENUMBRA_GPU_RAY_QUERIES_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

struct GpuRay {
  vec3 org;
  float tnear;
  vec3 dir;
  float tfar;
};

struct GpuRayHit {
  float t;
  uint object;
  uint prim;
  float u;
  float v;
};

struct RayQueryParams {
  uint64_t scene;
  uint64_t rays;     // GpuRay[count]
  uint64_t results;  // float[count] (transmittance) or GpuRayHit[count]
  uint count;
  uint pad;
};

PN_SHARED_END

#endif  // PENUMBRA_GPU_RAY_QUERIES_SHARED_H
