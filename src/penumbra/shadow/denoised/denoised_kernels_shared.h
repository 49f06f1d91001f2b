// `rt-denoised` on the GPU (denoised_gpu.cpp): its buffers and kernel parameters, byte by byte.
// Common subset of C++ and GLSL (core/shader_compat.h), scalar block layout.
//
// The guided images (atrous_filter.h GuidedImage) live in the view-sample slots: one plane per
// quantity with one element per slot, so the image of camera-ray index `sub` is every slot with
// that index (atrous_shared.h DenoiseImage: pixel stride = samples per pixel, offset = sub), as
// the CPU filters one image per index. S, U, A and the variance are kept twice, for the a-trous
// passes to read one set and write the other.
//
// Kernels, in order: dn_fans (one thread per slot: the fan of light samples, the planes),
// dn_gradients (the depth gradients), dn_spatial_variance (below 4 samples: §4.1's estimate,
// into `prefiltered`, then copied over the variance), per iteration dn_prefilter_variance and
// dn_atrous, then dn_ratio (V and E per slot).
#ifndef PENUMBRA_SHADOW_DENOISED_DENOISED_KERNELS_SHARED_H
#define PENUMBRA_SHADOW_DENOISED_DENOISED_KERNELS_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/shadow/shadow_rays_shared.h"

PN_SHARED_BEGIN

// The planes' addresses, 104 bytes (a record uploaded when they are allocated): bytes 0-7 valid
// (uint8 per slot: a surface), 8-15 depth (float), 16-23 normal (vec3), 24-31 grad (vec2: the
// depth gradient), 32-39 prefiltered (float: the prefiltered variance, or the spatial estimate
// before it is copied), 40-55 shadowed[2], 56-71 unshadowed[2], 72-87 area[2] (the area
// fraction A), 88-103 variance[2] (float each).
struct DnPlanes {
  uint64_t valid;
  uint64_t depth;
  uint64_t normal;
  uint64_t grad;
  uint64_t prefiltered;
  uint64_t shadowed[2];
  uint64_t unshadowed[2];
  uint64_t area[2];
  uint64_t variance[2];
};

// dn_fans.comp: one thread per slot; the planes' set 0. 120 bytes: the reference's fans
// (shadow/shadow_rays_shared.h; its visibility and irradiance unused), the planes, and the
// camera's eye and unit forward axis (the depth guide).
struct DnFansParams {
  LightFansParams fans;
  uint64_t planes;  // DnPlanes
  vec3 eye;
  vec3 forward;
};

// The filter's kernels: one thread per slot. 88 bytes.
struct DnFilterParams {
  uint64_t planes;       // DnPlanes
  uint64_t visibility;   // float per slot: V (dn_visibility)
  uint64_t irradiance;   // vec3 per slot: E, dn_ratio x the closed-form unshadowed irradiance
  uint64_t samples;      // GpuViewSample[slots]
  uint64_t light;        // the light's GpuLight
  uint64_t unit_circle;  // float[512] (scene/light.h unit_circle_table)
  uint slots;
  int width;  // the rendered window's
  int height;
  int spp;
  int step;      // the a-trous pass's tap spacing
  uint current;  // the set of S, U, A and variance that holds the image (0 or 1)
  float sigma_z;
  float sigma_n;
  float sigma_l;
  uint pad0;
};

// The most light samples a view sample draws (the method's `samples`).
PN_CONST int kDenoiseMaxSamples = 8;

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::DnPlanes) == 104);
static_assert(sizeof(penumbra::shader::DnFansParams) == 120);
static_assert(sizeof(penumbra::shader::DnFilterParams) == 88);
#endif

#endif  // PENUMBRA_SHADOW_DENOISED_DENOISED_KERNELS_SHARED_H
