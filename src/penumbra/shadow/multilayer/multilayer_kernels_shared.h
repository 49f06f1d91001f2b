// `mlsm` and `mtsm` on the GPU (multilayer_gpu.cpp): the kernels' parameters and buffers, byte by
// byte. Common subset of C++ and GLSL (core/shader_compat.h), scalar block layout.
//
// The frame of one light (stages "build" and "trace", the CPU's phases):
//   multilayer_fit_receivers  one thread per view-sample slot: the receivers (in front of the
//                             light), their bounds, and for each planar object whether some
//                             receiver lies behind it (caster_boxes); read back, 28 + 4 bytes a
//                             plane;
//   multilayer_fit_shadowable one thread per slot: which receivers a caster box can shadow
//                             (shadowable_receivers), a flag per slot, and the ranges of the kept
//                             and of all receivers in the view from the light's centre; read back;
//   multilayer_fit_crossings  one thread per slot: the range, in the pushed-back view (eq. 4), of
//                             the fitted receivers and of their segments' crossings of z_c toward
//                             the light's outline; read back. The host builds each view with the
//                             CPU's code (build_shadow_view, plan_push_back).
//   the GPU rasterizer's k-layer map (mlsm) or fragment lists (mtsm, then mtsm_compress: each
//   texel's list compressed into layers, xie2007 §5.1), the texels' ranges (window depth) and
//   the min/max pyramid (gpu/minmax_pyramid_gpu.h);
//   mlsm_trace / mtsm_trace   one thread per slot: the CPU's light samples, each ray walked
//                             through the pyramid (raster/depth_image_walk_shared.h) with the
//                             CPU's leaf tests (multilayer_trace_shared.h), V = sum T a / sum a.
#ifndef PENUMBRA_SHADOW_MULTILAYER_MULTILAYER_KERNELS_SHARED_H
#define PENUMBRA_SHADOW_MULTILAYER_MULTILAYER_KERNELS_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/raster_shared.h"
#include "penumbra/raster/shadow_view_shared.h"
#include "penumbra/shadow/multilayer/multilayer_trace_shared.h"

PN_SHARED_BEGIN

// The receivers, 28 bytes (multilayer_fit_receivers): bytes 0-3 how many; 4-15 the bounds' lower
// corner and 16-27 its upper corner as raster_order_bits (atomic min and max: the CPU's floats).
struct MlReceivers {
  uint count;
  uint lo_x;
  uint lo_y;
  uint lo_z;
  uint hi_x;
  uint hi_y;
  uint hi_z;
};

// A planar object's plane as caster_boxes tests it, 24 bytes: n, d (dot(n, x) = d), the light
// centre's side and the tolerance (ml_behind_plane).
struct MlPlane {
  vec3 n;
  float d;
  float side;
  float tol;
};

// What the second and third fit passes read, 208 bytes, uploaded before each: the view frames
// from the light's centre and from the pushed-back eye, the light, the crossings' set-up
// (PushBackPlan) and the counts of the arrays beside it.
struct MlFitBlock {
  ShadowViewAxes centre;
  ShadowViewAxes pushed;
  vec3 light_center;
  float z_c;
  vec3 light_n;
  uint n_outline16;  // shadowable_receivers' outline (16 points)
  vec3 eye;
  uint n_boxes;
  vec3 dir;
  uint crossings;    // 1: the second fit takes the crossings of z_c (else the receivers only)
  uint n_outline32;  // plan_push_back's outline
  uint kept_only;    // 1: the third pass fits the kept receivers (some were kept), 0: all
  uint pad0;
  uint pad1;
};

// multilayer_fit_receivers.comp's push constants.
struct MlFitReceiversParams {
  uint64_t samples;  // GpuViewSample[slots]
  uint64_t state;    // MlReceivers
  uint64_t planes;   // MlPlane[n_planes]
  uint64_t behind;   // uint per plane: 1 when some receiver lies behind it
  vec3 light_center;
  uint slots;
  vec3 light_n;
  uint n_planes;
};

// multilayer_fit_shadowable.comp's and multilayer_fit_crossings.comp's push constants. The ranges
// are three GpuReceiverRange (shadow_map_kernels_shared.h): 0 the kept receivers and 1 all of
// them in the centre's view, 2 the fitted points in the pushed-back view.
struct MlFitParams {
  uint64_t samples;
  uint64_t block;      // MlFitBlock
  uint64_t ranges;     // GpuReceiverRange[3]
  uint64_t keep;       // uint per slot: 1 when the receiver is kept (shadowable)
  uint64_t outline16;  // float[3 n_outline16]
  uint64_t boxes;      // float[6 n_boxes]: lo, hi
  uint64_t outline32;  // float[3 n_outline32]
  uint slots;
  uint pad;
};

// What the traces read besides their buffers, 224 bytes, uploaded with each map: its view
// (LightView::shared), the resolved trace set-up, its pyramid's level table, its size and layers.
struct MlTraceBlock {
  RasterView view;
  MlTraceSetup setup;
  uint64_t levels;
  int width;
  int height;
  int k;  // mlsm's layers per texel
  int level_count;
};

// What the traces count, 56 bytes (added to by one atomic per subgroup): rays, quadtree nodes
// tested, texels reached, layers tested, layer hits (MlTraceCounters summed), the rays the map
// could not answer for, traced whole (mlsm's kMlUnresolved), the loop-limit flag.
struct MlGpuCounters {
  uint64_t rays;
  uint64_t nodes;
  uint64_t texels;
  uint64_t tested;
  uint64_t hits;
  uint64_t unresolved;
  // Some thread ran into the driver's loop limit (lavapipe: 65535 loop iterations per invocation,
  // after which loops stop without an error; docs/gpu.md): its V is wrong, the render an error.
  uint64_t limited;
};

// What the traces of one evaluate read besides their push constants, 40 bytes, uploaded with
// each: the `reference` stream's key, the light samples and their grid, and where a view sample's
// partial sums wait between dispatches.
struct MlTraceFrame {
  uint64_t seed;
  uint64_t sums;  // vec2 per slot: sum of T a and of a over the light samples traced so far
  int light_index;
  int frame;
  int n;          // light samples
  int grid_cols;  // StratifiedGrid(n)
  float inv_cols;
  float inv_rows;
};

// mlsm_trace.comp's and mtsm_trace.comp's push constants. The map's buffers: mlsm counts,
// samples (map_a, map_b); mtsm offsets, layer counts, layers (map_a, map_b, map_c). One dispatch
// traces light samples [first_sample, first_sample + sample_count) of every view sample (all of
// them, unless the driver limits one invocation's loops: lavapipe).
struct MlTraceParams {
  uint64_t scene;
  uint64_t samples;     // GpuViewSample[slots]
  uint64_t light;       // GpuLight
  uint64_t visibility;  // float per slot
  uint64_t block;       // MlTraceBlock
  uint64_t nodes;       // the pyramid (gpu/minmax_pyramid_shared.h)
  uint64_t map_a;
  uint64_t map_b;
  uint64_t map_c;
  uint64_t counters;    // MlGpuCounters
  uint64_t trace_frame; // MlTraceFrame
  uint slots;
  uint has_map;   // 0: no receiver in front of the light, every V is 0
  int first_sample;
  int sample_count;
  int canary;     // 2: a loop of this many iterations tells whether the driver's loop limit was hit
};

// The map's statistics, 24 bytes (the CPU's extra.map): covered texels, layers in all, the most
// in one texel, and (mtsm) the smallest z as raster_order_bits.
struct MlMapCounters {
  uint64_t covered;
  uint64_t layers;
  uint max_layers;
  uint z_min_bits;
};

// mlsm_layer_ranges.comp's and mtsm_compress.comp's push constants.
struct MlMapParams {
  uint64_t block;     // MlTraceBlock (its view)
  uint64_t nodes;     // the pyramid: level 0 written (window depth ranges)
  uint64_t map_a;     // mlsm: counts; mtsm: the fragment lists' offsets
  uint64_t map_b;     // mlsm: samples; mtsm: the fragments
  uint64_t map_c;     // mtsm: layer counts (uint per texel)
  uint64_t map_d;     // mtsm: layers (TransparentLayer, at the fragment offsets)
  uint64_t counters;  // MlMapCounters
  uint texels;
  float error;        // mtsm: CompressionOptions
  int resets;
  float zero;
  uint unknown_beyond_full;  // a full texel's range reaches kMlBeyondFullTexel (the method's unresolved=trace)
  uint pad;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::MlReceivers) == 28);
static_assert(sizeof(penumbra::shader::MlPlane) == 24);
static_assert(sizeof(penumbra::shader::MlFitBlock) == 208);
static_assert(sizeof(penumbra::shader::MlTraceBlock) == 224);
static_assert(sizeof(penumbra::shader::MlGpuCounters) == 56);
static_assert(sizeof(penumbra::shader::MlTraceFrame) == 40);
static_assert(sizeof(penumbra::shader::MlMapCounters) == 24);
static_assert(sizeof(penumbra::shader::MlFitReceiversParams) <= 128);
static_assert(sizeof(penumbra::shader::MlFitParams) <= 128);
static_assert(sizeof(penumbra::shader::MlTraceParams) <= 128);
static_assert(sizeof(penumbra::shader::MlMapParams) <= 128);
#endif

#endif  // PENUMBRA_SHADOW_MULTILAYER_MULTILAYER_KERNELS_SHARED_H
