// `occlusion-textures` on the GPU (occlusion_textures_gpu.cpp): its buffers and kernel
// parameters, byte by byte. Common subset of C++ and GLSL (core/shader_compat.h), scalar block
// layout. The records the kernels read are occlusion_shared.h's OtSetup; the coverage masks are
// the GPU rasterizer's depth-bin masks (gpu/raster/gpu_depth_bins.h: a uint per texel, bit k =
// slice k); the summed-area tables are gpu/filtered/'s.
//
// Prepare (per light): the slicing pass (the rasterizer's depth-bin mode), ot_thin_fix (one thread
// per texel: each slice's coverage also into the next), then the prefilter: ot_slice_bounds (one
// thread per texel: each slice's covered rectangle), ot_expand_bits (one thread per texel and
// slice: level 0 of the 8-bit pyramids) and a level at a time ot_mip_level or ot_nbuffer_level
// (one thread per texel or anchor and slice), or the summed-area tables. Per frame: ot_shade (one
// thread per view-sample slot: occlusion_shared.h ot_visibility).
#ifndef PENUMBRA_SHADOW_OCCLUSION_TEXTURES_OCCLUSION_KERNELS_SHARED_H
#define PENUMBRA_SHADOW_OCCLUSION_TEXTURES_OCCLUSION_KERNELS_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/filtered_map_shared.h"

PN_SHARED_BEGIN

// Every slice's covered rectangle: 4 floats a slice (x0, y0, x1, y1: occlusion_shared.h
// OtSliceBounds), reduced as their bits (order-preserving for floats >= 0); before any texel x0
// = width, y0 = height, x1 = y1 = 0 (an empty slice: x0 >= x1).

// What the lookups count, 40 bytes: lookups, texels read, kernels outside the texture, elongated
// kernels, near fields traced (uint64 each).
struct OtShadeCounters {
  uint64_t lookups;
  uint64_t reads;
  uint64_t outside;
  uint64_t strips;
  uint64_t near_rays;
};

// ot_thin_fix.comp and ot_slice_bounds.comp: one thread per texel.
struct OtMaskParams {
  uint64_t masks;   // uint per texel
  uint64_t bounds;  // float[4 slices] (ot_slice_bounds)
  int width;
  int height;
  int slices;
  uint all;  // the mask of every slice's bit (ot_thin_fix)
};

// ot_expand_bits.comp, ot_mip_level.comp and ot_nbuffer_level.comp: one thread per texel (or
// anchor) of the level written and slice. The pyramid's planes: slice k of a level at
// offset + k * plane (bytes).
struct OtPyramidParams {
  uint64_t masks;  // ot_expand_bits: the coverage masks
  uint64_t bytes;  // the pyramid
  uint src_offset;  // the level read: its first plane, its plane size, its width and height
  uint src_plane;
  int src_width;
  int src_height;
  uint dst_offset;  // the level written, likewise
  uint dst_plane;
  int dst_width;
  int dst_height;
  int slices;
  int step;  // ot_nbuffer_level: 2^l, the offset of the four boxes read
};

// ot_shade.comp: one thread per view-sample slot.
struct OtShadeParams {
  uint64_t samples;     // GpuViewSample[slots]
  uint64_t visibility;  // float per slot
  uint64_t setup;       // OtSetup, then its tiles' OtTile records (at kOtSetupBytes)
  uint64_t textures;    // the pyramid (bytes) or the summed-area tables (uint32 or double)
  uint64_t bounds;      // float[4 slices]
  uint64_t counters;    // OtShadeCounters
  uint64_t scene;       // the GpuScene (the receivers' objects: closed or not)
  uint64_t nearest;     // the slices' nearest depths (ot_own_slice), 0: own_slice off
  int nearest_scale;    // their texels a side per the texture's (own_slice_scale)
  uint slots;
  uint prefilter;   // kOt*
  uint sat_counts;  // the tables hold uint32 counts
  int width;        // the texture's side
  int height;
  int levels;  // the pyramid's
  SatTableLayout sat;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::OtShadeCounters) == 40);
static_assert(sizeof(penumbra::shader::OtMaskParams) <= 128);
static_assert(sizeof(penumbra::shader::OtPyramidParams) <= 128);
static_assert(sizeof(penumbra::shader::OtShadeParams) <= 128);
#endif

#endif  // PENUMBRA_SHADOW_OCCLUSION_TEXTURES_OCCLUSION_KERNELS_SHARED_H
