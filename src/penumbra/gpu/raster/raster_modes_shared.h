// The GPU rasterizer's layered depth maps and fragment lists (gpu/raster/gpu_raster_modes.h;
// docs/raster.md), byte by byte: the modes beside the depth map (raster_layout_shared.h), which
// share its set-up (raster_setup, raster_fill_args) and its scan of a work item's fragments
// (raster_scan.glsl). Common subset of C++ and GLSL (core/shader_compat.h), scalar block layout.
//
// Layered depth map (xie2007 §4.2: the k nearest distinct surfaces per texel; the CPU's
// Rasterizer::layered_depth_map, distinct surfaces by raster/raster_layers_shared.h):
//   counts   uint per texel: layers present
//   samples  k per texel, texel-major (texel i's layer l at i * k + l), 16 bytes each: z (linear
//            depth), window depth, opacity, input triangle (raster/depth_map.h DepthSample);
//            only the first counts[i] of a texel are written
//   front    float per texel: the last peeled layer's z (-inf before the first, +inf where it is
//            empty), what the next peel compares with
//   keys     uint64 per texel: the peel's nearest candidate (raster_depth_key), ~0 where none
// Rendered by peeling (xie2007 §4.2 peels with the hardware depth test; here every peel is a
// compute pass): for l = 0 .. k - 1, raster_layer_peel keeps the nearest fragment that
// raster_layer_behind the texel's front, raster_layer_resolve writes it as layer l and makes it
// the front. The fragments that join a layer instead (within epsilon of its front) compose their
// opacity into it during the next peel (and one last pass for layer k - 1).
//
// Fragment lists (xie2007 §5, deep shadow input; the CPU's Rasterizer::fragment_lists):
//   counts     uint per texel: its fragments (raster_fragment_count), then the scatter's cursor
//   offsets    uint per texel + 1: the exclusive prefix sum of the counts (gpu/scan_gpu.h);
//              texel i owns fragments[offsets[i], offsets[i + 1]), offsets[texels] the total
//   fragments  12 bytes each: z, opacity, input triangle (penumbra::Fragment; MlFragment),
//              each texel's sorted by (z, triangle) by raster_fragment_sort, as the CPU's
// The fragments buffer holds `capacity` fragments; the scatter writes only those that fit and the
// host grows it to the total the scan counted and renders again (never drops work).
#ifndef PENUMBRA_GPU_RASTER_RASTER_MODES_SHARED_H
#define PENUMBRA_GPU_RASTER_RASTER_MODES_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// One fragment of a texel's list, 12 bytes (penumbra::Fragment).
struct GpuFragment {
  float z;
  float opacity;
  uint triangle;
};

// raster_layer_peel.comp's push constants.
struct RasterPeelParams {
  uint64_t scene;
  uint64_t view;
  uint64_t state;
  uint64_t triangles;
  uint64_t items;
  uint64_t keys;
  uint64_t front;
  uint64_t samples;
  uint item_capacity;
  uint layer;      // the layer peeled (k: the last pass, which only joins layer k - 1)
  uint k;
  float epsilon;   // LayerOptions::distinct_epsilon
};

// raster_layer_resolve.comp's push constants.
struct RasterLayerResolveParams {
  uint64_t scene;
  uint64_t view;
  uint64_t state;
  uint64_t keys;
  uint64_t front;
  uint64_t samples;
  uint64_t counts;
  uint layer;
  uint k;
};

// raster_fragment_count.comp's and raster_fragment_scatter.comp's push constants.
struct RasterFragmentParams {
  uint64_t scene;
  uint64_t view;
  uint64_t state;
  uint64_t triangles;
  uint64_t items;
  uint64_t counts;
  uint64_t offsets;
  uint64_t fragments;
  uint item_capacity;
  uint fragment_capacity;
};

// raster_fragment_sort.comp's push constants.
struct RasterFragmentSortParams {
  uint64_t offsets;
  uint64_t fragments;
  uint texels;
  uint fragment_capacity;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::GpuFragment) == 12);
static_assert(sizeof(penumbra::shader::RasterPeelParams) <= 128);
static_assert(sizeof(penumbra::shader::RasterLayerResolveParams) <= 128);
static_assert(sizeof(penumbra::shader::RasterFragmentParams) <= 128);
static_assert(sizeof(penumbra::shader::RasterFragmentSortParams) <= 128);
#endif

#endif  // PENUMBRA_GPU_RASTER_RASTER_MODES_SHARED_H
