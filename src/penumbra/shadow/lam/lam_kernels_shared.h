// `lam` on the GPU, byte by byte (lam_gpu.cpp; docs/methods/lam.md, "On the GPU"): the LDI built
// from the light samples' depth maps (kernels/lam_insert.comp, kernels/lam_finalize.comp) and its
// display (kernels/lam_display.comp). Common subset of C++ and GLSL (core/shader_compat.h), scalar
// block layout. The per-pixel and per-texel math is lam_shared.h's, the CPU's.
//
// Buffers:
//   build layers  LamBuildLayer[max_layers x texels], slot i of reference texel t at i x texels + t
//                 (layer-major, as the CPU's builder stores them: most texels have one or two)
//   counts        uint per reference texel: its layers so far
//   samples       LamSampleView per light sample of a batch
//   splat lists   per reference texel, list_capacity LamSplatEntry slots and a count: the splats
//                 one light sample's pixels sent it (kernels/lam_scatter.comp), in any order
//   sample counts LamSampleCounts per light sample: the layers and the non-empty texels it added
//                 (agrawala2000 Fig. 10's depth complexity after k samples)
//   counters      LamCounters
//   ranges        two uints per reference texel: its layers are [first, end) of
//   layers        two floats per layer (z, attenuation), each texel's nearest first (lam_shared.h)
#ifndef PENUMBRA_SHADOW_LAM_LAM_KERNELS_SHARED_H
#define PENUMBRA_SHADOW_LAM_LAM_KERNELS_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/shadow/lam/lam_shared.h"

PN_SHARED_BEGIN

// A layer while building, 20 bytes (the CPU's BuildLayer): bytes 0-3 its running mean depth, 4-7
// its count: the light samples that counted it, or for a weighted layer (an open surface's with
// weighted_splats: lam_shared.h, "Counting a layer") the sum of the weights they added, 8-11
// (weighted) what the sample of the stamp has added so far, 12-15 (weighted) the most one sample
// added, or < 0 for a layer counted once per sample, 16-19 the light samples that matched it (bits
// 0-15: the running mean's count) and 1 + the index of the last one (bits 16-31).
struct LamBuildLayer {
  float z;
  float count;
  float weight;
  float peak;
  uint hits_stamp;
};

// One light sample's view in a batch, 32 bytes: bytes 0-7 (ox, oy) its texel-space origin in whole
// reference texels (lam::sample_view), 8-15 (bx, by) its displacement from the light centre along
// the view's right and up axes in reference texels at unit depth, 16-23 its width and height,
// 24-31 first_texel: where its keys start in the batch (gpu/raster/gpu_batch_rasterizer.h).
struct LamSampleView {
  int ox;
  int oy;
  float bx;
  float by;
  int width;
  int height;
  uint64_t first_texel;
};

// A splat sent to a texel, 12 bytes: bytes 0-3 the pixel of the sample's map it came from (y x
// width + x: its place in the scan order the CPU inserts in), 4-7 its depth at the texel's centre,
// 8-11 its weight there (lam_shared.h lam_splat_weight).
struct LamSplatEntry {
  uint pixel;
  float z;
  float weight;
};

// 8 bytes per light sample: bytes 0-3 layers it created, 4-7 texels it made non-empty.
struct LamSampleCounts {
  uint layers;
  uint nonempty;
};

// 48 bytes: bytes 0-7 splats (texel insertions attempted), 8-15 dropped (insertions lost to
// max_layers), 16-19 the most layers of one texel, 20-23 layers allocated by the finalize,
// 24-31 texels the display read, 32-39 view samples it traced (kLamUnresolved), 40-47 their rays.
struct LamCounters {
  uint64_t splats;
  uint64_t dropped;
  uint max_depth;
  uint allocated;
  uint64_t texels;
  uint64_t traced;
  uint64_t rays;
};

// lam_scatter.comp (one thread per pixel of one light sample's map) and lam_insert.comp (one
// thread per reference texel), for one light sample.
struct LamInsertParams {
  uint64_t keys;           // the sample's depth map (raster_depth_key per texel)
  uint64_t view;           // its LamSampleView
  uint64_t layers;         // LamBuildLayer[max_layers x texels]
  uint64_t counts;         // uint[texels]: layers
  uint64_t lists;          // LamSplatEntry[list_capacity x texels]
  uint64_t list_counts;    // uint[texels]: splats sent (may exceed list_capacity; 0 after the insert)
  uint64_t sample_counts;  // LamSampleCounts[light samples]
  uint64_t counters;       // LamCounters
  uint64_t scene;          // SceneDesc (lam_insert: whether a splat's triangle is of a closed object)
  int width;               // the reference view
  int height;
  float near;  // its depth range (every sample view's)
  float far;
  float epsilon;
  uint max_layers;
  uint index;  // the light sample's index (stamps are index + 1)
  uint list_capacity;
  uint slope;  // 1: local planes
  uint pixels;  // of the sample's map
  float open_epsilon;  // the tolerance of open surfaces' splats (epsilon without local planes)
  uint weighted;       // 1: open surfaces' layers add their splats' weights (weighted_splats with local planes)
};
// lam_finalize.comp: one thread per reference texel.
struct LamFinalizeParams {
  uint64_t build;     // LamBuildLayer[max_layers x texels]
  uint64_t counts;    // uint[texels]
  uint64_t ranges;    // uint[2 texels]
  uint64_t layers;    // float[2 x layers]
  uint64_t counters;  // LamCounters
  uint texels;
  float inv_samples;  // 1 / light samples
};

// lam_display.comp: one thread per view-sample slot.
struct LamDisplayParams {
  uint64_t scene;       // SceneDesc (objects: which are closed)
  uint64_t samples;     // GpuViewSample[slots]
  uint64_t visibility;  // float per slot
  uint64_t layers;      // float[2 x layers]
  uint64_t ranges;      // uint[2 texels]
  uint64_t outline;     // float[3 x outline points]
  uint64_t view;        // LamMapView
  uint64_t counters;    // LamCounters
  uint64_t points;      // vec3[point_count]: the LDI's light samples on the light (sample_area)
  uint slots;
  uint bilinear;  // 1: the 4 texels around p; 0: the nearest
  uint point_count;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::LamBuildLayer) == 20);
static_assert(sizeof(penumbra::shader::LamSampleView) == 32);
static_assert(sizeof(penumbra::shader::LamSampleCounts) == 8);
static_assert(sizeof(penumbra::shader::LamSplatEntry) == 12);
static_assert(sizeof(penumbra::shader::LamCounters) == 48);
static_assert(sizeof(penumbra::shader::LamInsertParams) <= 128);
static_assert(sizeof(penumbra::shader::LamFinalizeParams) <= 128);
static_assert(sizeof(penumbra::shader::LamDisplayParams) <= 128);
#endif

#endif  // PENUMBRA_SHADOW_LAM_LAM_KERNELS_SHARED_H
