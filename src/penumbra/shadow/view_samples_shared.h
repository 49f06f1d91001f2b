// The view samples on the GPU (the G-buffer every GPU method reads), in the common subset of C++
// and GLSL: one 64-byte record per camera ray of the rendered window, in the byte layout of the
// CPU's ViewSample (shadow/view_samples.h; static_asserts below), so a record downloaded from the
// GPU is a ViewSample. Unlike the CPU's list of hits, the GPU keeps every camera ray's slot (slot
// = (row within the window * window width + column) * samples per pixel + sub) and marks a ray
// that hit nothing with object = kMissObject: no compaction pass, and a pixel's rays are found
// by index.
//   bytes 0-11 p   12-23 ng   24-35 ns   36-47 albedo   48-51 object   52-55 prim
//   bytes 56-59 pixel (y * image width + x)   60-63 sub (the ray's index within its pixel)
#ifndef PENUMBRA_SHADOW_VIEW_SAMPLES_SHARED_H
#define PENUMBRA_SHADOW_VIEW_SAMPLES_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/gpu/scene_layout_shared.h"  // kMissObject

PN_SHARED_BEGIN

struct GpuViewSample {
  vec3 p;
  vec3 ng;
  vec3 ns;
  vec3 albedo;
  uint object;
  uint prim;
  uint pixel;
  uint sub;
};

// sample_key (view_samples.h): the key every method's random numbers for a view sample derive
// from, its camera ray.
PN_INLINE uint64_t gpu_sample_key(GpuViewSample s) { return (uint64_t(s.pixel) << 32) | uint64_t(s.sub); }

PN_SHARED_END

#endif  // PENUMBRA_SHADOW_VIEW_SAMPLES_SHARED_H
