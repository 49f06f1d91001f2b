// The shadow-map methods' GPU buffers and kernel parameters, byte by byte (shadow/
// shadow_map_common_gpu.h, shadow/baseline/shadow_map_gpu.cpp, pcss_gpu.cpp): the fit of the light view
// to the receivers (shadow/kernels/shadow_fit_receivers.comp), the hard lookup and PCF
// (baseline/kernels/shadow_map_lookup.comp) and PCSS (baseline/kernels/pcss_filter.comp). Common
// subset of C++ and GLSL (core/shader_compat.h), scalar block layout.
#ifndef PENUMBRA_SHADOW_SHADOW_MAP_KERNELS_SHARED_H
#define PENUMBRA_SHADOW_SHADOW_MAP_KERNELS_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/shadow_view_shared.h"
#include "penumbra/shadow/shadow_map_shared.h"

PN_SHARED_BEGIN

// The receivers' extents in a fitted view's frame (raster/shadow_view.h reduce_receivers, on the
// device), 32 bytes:
//   bytes 0-23 x0 x1 y0 y1 z0 z1: raster_order_bits of the smallest x/z, largest x/z, smallest
//              y/z, largest y/z, smallest z, largest z (before any receiver: 0xffffffff for the
//              smallest, 0 for the largest)
//   bytes 24-27 receivers: view samples in front of the light (hits only)
//   bytes 28-31 fitted: those of them at linear depth >= min_near
struct GpuReceiverRange {
  uint x0;
  uint x1;
  uint y0;
  uint y1;
  uint z0;
  uint z1;
  uint receivers;
  uint fitted;
};

// shadow_fit_receivers.comp: one thread per view-sample slot.
struct FitReceiversParams {
  uint64_t samples;  // GpuViewSample[slots]
  uint64_t range;    // GpuReceiverRange
  ShadowViewAxes axes;
  vec3 light_center;  // receivers: dot(p - light_center, light_n) > 0
  uint slots;
  vec3 light_n;
  uint pad;
};

// A map as the lookups read it, 192 bytes, uploaded when the map is rendered: bytes 0-175 the
// ShadowMapView (shadow/shadow_map_shared.h), 176-191 the method's ShadowBias.
struct ShadowMapBlock {
  ShadowMapView map;
  ShadowBias bias;
};

// What the lookup kernels count, 24 bytes: bytes 0-7 texels read, 8-11 receivers outside the map
// (MethodStats extra receivers_outside_map), 12-15 view samples whose blocker search found none
// (pcss fernando: samples_without_blockers), 16-19 near fields traced (vsm, evsm, msm:
// near_field_rays), 20-23 (0).
struct GpuShadowMapCounters {
  uint64_t texels;
  uint outside;
  uint no_blocker;
  uint near_rays;
  uint pad;
};

// What every lookup kernel reads and writes, 64 bytes (GpuLightCentreMap::lookup_inputs).
struct ShadowMapInputs {
  uint64_t scene;       // SceneDesc (objects: which are closed)
  uint64_t samples;     // GpuViewSample[slots]
  uint64_t visibility;  // float per slot
  uint64_t z;           // the map's planes (GpuDepthMap; 0 without a map)
  uint64_t opacity;
  uint64_t block;     // ShadowMapBlock
  uint64_t counters;  // GpuShadowMapCounters
  uint slots;
  uint has_map;  // 0: no receiver in front of the light, every V is 0
};

// shadow_map_lookup.comp: one thread per view-sample slot.
struct ShadowMapLookupParams {
  ShadowMapInputs io;
  vec3 light_center;  // V = 0 where dot(p - light_center, light_n) <= 0
  int pcf;            // the (2 pcf + 1)^2 box of texels
  vec3 light_n;
  uint bilinear;      // 1: the box slides between texel centres (shadow_map_visibility)
};

// pcss_filter.comp: one thread per view-sample slot.
struct PcssFilterParams {
  ShadowMapInputs io;
  uint64_t light;         // GpuLight (gpu/light_layout_shared.h): geometry and sampling table
  uint64_t blocker_base;  // float[2 blocker_samples]: LightSampleSet::base
  uint64_t pcf_base;      // float[2 pcf_samples]
  uint64_t key;           // the kernels' key: the per-pixel shift is Rng(key, 0x5050, pixel)
  int blocker_samples;
  int pcf_samples;
  uint xie2007;
  uint jitter;
  float extent_radius;  // AreaLight::extent_radius
  uint pad;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::GpuReceiverRange) == 32);
static_assert(sizeof(penumbra::shader::FitReceiversParams) <= 128);
static_assert(sizeof(penumbra::shader::ShadowMapBlock) == 192);
static_assert(sizeof(penumbra::shader::GpuShadowMapCounters) == 24);
static_assert(sizeof(penumbra::shader::ShadowMapInputs) == 64);
static_assert(sizeof(penumbra::shader::ShadowMapLookupParams) <= 128);
static_assert(sizeof(penumbra::shader::PcssFilterParams) <= 128);
#endif

#endif  // PENUMBRA_SHADOW_SHADOW_MAP_KERNELS_SHARED_H
