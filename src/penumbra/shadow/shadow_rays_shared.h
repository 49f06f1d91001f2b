// The parameters of the shadow-ray kernels on the GPU (shadow/reference/reference_fans.comp,
// shadow/baseline/hard_rays.comp): the GPU versions of shadow_rays.h. Common subset of C++ and
// GLSL; buffers are device addresses.
#ifndef PENUMBRA_SHADOW_SHADOW_RAYS_SHARED_H
#define PENUMBRA_SHADOW_SHADOW_RAYS_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// trace_light_fans: n stratified light samples per view sample, keyed as the CPU keys them.
struct LightFansParams {
  uint64_t scene;       // SceneDesc
  uint64_t samples;     // GpuViewSample[slots]
  uint64_t light;       // GpuLight
  uint64_t visibility;  // float per slot: V = sum T a / sum a
  uint64_t irradiance;  // vec3 per slot: E = L / n sum T f
  uint64_t rays;        // uint64: shadow rays traced, added to
  uint64_t seed;
  uint slots;
  int light_index;
  int frame;
  int n;
  int grid_cols;  // StratifiedGrid(n)
  float inv_cols;
  float inv_rows;
  uint area_sampling;  // 1: uniform area samples (reference's sampling=area)
};

// reference_fans: the light fans' samples [first, first + count) of n per dispatch, so that no
// thread's loops meet a driver's loop limit (gpu/loop_limit.h). The sums run on in `partial`
// between dispatches, in the CPU's order: the same float additions as one loop over all n.
struct ReferenceFansParams {
  LightFansParams fans;  // fans.rays: uint64[2], the rays traced and (1) whether a thread was cut short
  uint64_t partial;      // vec3 per slot: e, sum T a and sum a over the samples before `first`
  int first;
  int count;
  int canary;  // gpu::kLoopLimitCanary
};

// transmittance_to_point: one segment per view sample to `target` (hard shadows).
struct PointRaysParams {
  uint64_t scene;
  uint64_t samples;
  uint64_t visibility;  // float per slot
  vec3 target;
  uint slots;
};

PN_SHARED_END

#endif  // PENUMBRA_SHADOW_SHADOW_RAYS_SHARED_H
