// `multi-view-sm` on the GPU, byte by byte (multi_view_shadow_map_gpu.cpp): the fit of every light
// point's view to the receivers (kernels/multi_view_fit.comp) and the lookups of each view sample
// in a batch of maps (kernels/multi_view_lookup.comp, shadow_map_shared.h's sm_lookup: the CPU's
// function). Common subset of C++ and GLSL (core/shader_compat.h), scalar block layout.
#ifndef PENUMBRA_SHADOW_BASELINE_MULTI_VIEW_SHARED_H
#define PENUMBRA_SHADOW_BASELINE_MULTI_VIEW_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/shadow_view_shared.h"
#include "penumbra/shadow/shadow_map_shared.h"

PN_SHARED_BEGIN

// One map of a batch as the lookups read it, 184 bytes: bytes 0-175 its ShadowMapView
// (shadow_map_shared.h), 176-183 first_texel: where its texels start in the batch's z and opacity
// planes (gpu/raster/gpu_batch_rasterizer.h GpuDepthMapBatch).
struct MultiViewMap {
  ShadowMapView map;
  uint64_t first_texel;
};

// The near field (docs/methods/multi-view-sm.md "The near field"): shadow_map_shared.h's
// sm_near_field_length of each map, from its light point. There the map's answer is a texel-sized
// hard shadow that the maps' average does not turn into the penumbra (every map's texels lie on the
// same receivers), so the shadow ray is traced through the scene itself, and the map answers for
// the rest: mv_far_lookup, the map's answer for p's segment to its eye beyond `near` of p. Seen
// from the eye, the whole segment is p's own texel, and the point `near` along it toward the eye
// has the linear depth z_p (1 - near / |eye - p|): a surface of the texel in front of that depth
// (and of the biased reference depth, which still keeps p's own surface out) blocks; one behind
// it lies in the near field, which the ray traces. near 0: sm_lookup.
PN_INLINE float mv_far_lookup(PN_FLOAT_ARRAY zs, PN_FLOAT_ARRAY opacity, ShadowMapView m, vec3 p, vec3 ng, bool closed,
                              ShadowBias b, float near) {
  float cut = uintBitsToFloat(0x7f800000u);
  if (near > 0.0f) cut = dot(p - m.view.eye, m.view.forward) * (1.0f - near / length(m.view.eye - p));
  return sm_lookup_beyond(zs, opacity, m, p, ng, closed, b, cut);
}

// The part of p's segment to map m's eye that is traced: the near field (sm_near_field_length),
// or the whole segment where p lies outside the map (behind its near plane or beyond its window:
// a receiver more than max_fov / 2 off the light's axis from that light point). The map says
// nothing there, and such receivers counted as lit: a room lit through a window by a light just
// outside it lost the shadows of the walls beside the window so. 0 with near_field 0 (the maps
// alone).
PN_INLINE float mv_traced_length(ShadowMapView m, vec3 p, float near_field, float light_width) {
  if (!(near_field > 0.0f)) return 0.0f;
  if (sm_outside(m, p)) return length(m.view.eye - p);
  return sm_near_field_length(m, p, near_field, light_width);
}

// multi_view_fit.comp: one thread per view-sample slot, every light point's view in turn. The
// views share their axes and min_near (`axes`, its eye unused) and differ in their eye, the light
// point (vec3 per view). Each view's receivers reduce into its GpuReceiverRange
// (shadow_map_kernels_shared.h), as shadow_fit_receivers.comp reduces one view's.
struct MultiViewFitParams {
  ShadowViewAxes axes;
  uint64_t samples;  // GpuViewSample[slots]
  uint64_t ranges;   // GpuReceiverRange[views]
  uint64_t eyes;     // vec3[views]
  vec3 light_center;  // receivers: dot(p - light_center, light_n) > 0
  uint slots;
  vec3 light_n;
  uint views;
};

// multi_view_lookup.comp: one thread per view-sample slot, the batch's maps in order, each the
// hard lookup sm_lookup (shadow_map.cpp's, with the method's biases), or with a near field the
// map's answer beyond it (mv_far_lookup) times the near field's transmittance through the BVH
// where the map lets light through. V accumulates in the
// visibility buffer over the batches in the CPU's order: the first batch starts from 0, the last
// multiplies by 1 / maps. A view sample behind the light's plane gets 0.
struct MultiViewLookupParams {
  uint64_t scene;       // SceneDesc (objects: which are closed)
  uint64_t samples;     // GpuViewSample[slots]
  uint64_t visibility;  // float per slot
  uint64_t maps;        // MultiViewMap[map_count]
  uint64_t z;           // the batch's planes (float per texel)
  uint64_t opacity;
  uint64_t counters;  // uint64[2]: texels read, near fields traced
  ShadowBias bias;
  vec3 light_center;
  uint slots;
  vec3 light_n;
  uint map_count;
  uint first;  // 1: the first batch (V starts from 0)
  float scale;  // V is multiplied by it after this batch's maps: 1 / maps for the last, else 1
  float near_field;   // sm_near_field_length's texels (0: the maps alone)
  float light_width;  // near_field_light_width of the light
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::MultiViewMap) == 184);
static_assert(sizeof(penumbra::shader::MultiViewFitParams) <= 128);
static_assert(sizeof(penumbra::shader::MultiViewLookupParams) <= 128);
#endif

#endif  // PENUMBRA_SHADOW_BASELINE_MULTI_VIEW_SHARED_H
