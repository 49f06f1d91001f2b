// `rt-denoised` on the GPU (denoised_gpu.cpp): its buffers and kernel parameters, byte by byte.
// Common subset of C++ and GLSL (core/shader_compat.h), scalar block layout.
//
// The guided images (atrous_filter.h GuidedImage) live in the view-sample slots: one plane per
// quantity with one element per slot, so the image of camera-ray index `sub` is every slot with
// that index (atrous_shared.h DenoiseImage: pixel stride = samples per pixel, offset = sub), as
// the CPU filters one image per index. S, U and the variance are kept twice, for the a-trous
// passes to read one set and write the other.
//
// Kernels, in order: dn_fans (one thread per slot: the fan of light samples, the planes),
// dn_gradients (the depth gradients), dn_spatial_variance (below 4 samples: §4.1's estimate,
// into `prefiltered`, then copied over the variance), per iteration dn_prefilter_variance and
// dn_atrous, then dn_ratio (V per slot).
#ifndef PENUMBRA_SHADOW_DENOISED_DENOISED_KERNELS_SHARED_H
#define PENUMBRA_SHADOW_DENOISED_DENOISED_KERNELS_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/shadow/shadow_rays_shared.h"

PN_SHARED_BEGIN

// The planes' addresses, 104 bytes (a record uploaded when they are allocated): bytes 0-7 valid
// (uint8 per slot: a surface), 8-15 depth (float), 16-23 normal (vec3), 24-31 fallback (float),
// 32-39 grad (vec2: the depth gradient), 40-47 prefiltered (float: the prefiltered variance, or
// the spatial estimate before it is copied), 48-63 shadowed[2], 64-79 unshadowed[2], 80-95
// variance[2] (float each), 96-103 (0).
struct DnPlanes {
  uint64_t valid;
  uint64_t depth;
  uint64_t normal;
  uint64_t fallback;
  uint64_t grad;
  uint64_t prefiltered;
  uint64_t shadowed[2];
  uint64_t unshadowed[2];
  uint64_t variance[2];
  uint64_t pad;
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

// The filter's kernels: one thread per slot.
struct DnFilterParams {
  uint64_t planes;      // DnPlanes
  uint64_t visibility;  // float per slot (dn_ratio)
  uint slots;
  int width;  // the rendered window's
  int height;
  int spp;
  int step;      // the a-trous pass's tap spacing
  uint current;  // the set of S, U and variance that holds the image (0 or 1)
  float sigma_z;
  float sigma_n;
  float sigma_l;
  uint pad0;
  uint pad1;
  uint pad2;
};

// The most light samples a view sample draws (the method's `samples`).
PN_CONST int kDenoiseMaxSamples = 8;

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::DnPlanes) == 104);
static_assert(sizeof(penumbra::shader::DnFansParams) == 120);
static_assert(sizeof(penumbra::shader::DnFilterParams) == 64);
#endif

#endif  // PENUMBRA_SHADOW_DENOISED_DENOISED_KERNELS_SHARED_H
