// The GPU buffers and kernel parameters of `vsm`, `evsm` and `msm` (filtered_moments_gpu.cpp),
// byte by byte. Common subset of C++ and GLSL (core/shader_compat.h), scalar block layout. The
// records the kernels read are moments_shared.h's FmModel and filtered_moments_shared.h's
// FmShadeBlock and FmDepthRange; the moment map's tables are gpu/filtered/'s.
//
// Per map (when the light-centre map was rendered again): fm_depth_range (one thread per texel:
// the covered depths' extremes), fm_encode (one thread per texel: the depth range record and the
// texel's moments), then the summed-area table or mip chain (gpu/filtered/). Per frame:
// fm_filter (one thread per view-sample slot: filtered_moments_shared.h fm_shade).
#ifndef PENUMBRA_SHADOW_FILTERED_MOMENTS_FILTERED_MOMENTS_KERNELS_SHARED_H
#define PENUMBRA_SHADOW_FILTERED_MOMENTS_FILTERED_MOMENTS_KERNELS_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/filtered_map_shared.h"
#include "penumbra/shadow/shadow_map_kernels_shared.h"

PN_SHARED_BEGIN

// The covered depths' extremes, 8 bytes: bytes 0-3 raster_order_bits of the smallest z < +inf
// (0xffffffff before any), 4-7 of the largest (0 before any).
struct FmDepthBits {
  uint lo;
  uint hi;
};

// Where the moment map's prefiltered table is and how it is laid out, 72 bytes (uploaded when
// the table is built): bytes 0-3 prefilter (kFmPrefilter*), 4-7 width, 8-11 height, 12-15 (0),
// 16-39 the summed-area table's SatTableLayout, 40-71 the mip chain's MipChainView.
struct FmMapRecord {
  uint prefilter;
  int width;
  int height;
  uint pad;
  SatTableLayout sat;
  MipChainView mip;
};

// fm_depth_range.comp: one thread per texel of the depth map.
struct FmDepthRangeParams {
  uint64_t z;     // the map's linear depths (float per texel, +inf where empty)
  uint64_t bits;  // FmDepthBits (filled with its starting values first)
  uint texels;
  uint pad;
};

// fm_encode.comp: one thread per texel; the first also writes the FmDepthRange record.
struct FmEncodeParams {
  uint64_t z;
  uint64_t bits;     // FmDepthBits
  uint64_t range;    // FmDepthRange, written
  uint64_t model;    // FmModel
  uint64_t texels;   // float[texels][channels], written
  double near;       // FilteredMomentMap::kNear, kFar, kTinyRange
  double far;
  double tiny;
  uint count;        // texels
  uint pad;
};

// fm_filter.comp: one thread per view-sample slot. The map's planes in `io` are unused (the
// moments are read instead); its counters get 16 texels per channel and lookup, the receivers
// outside the map, and the view samples whose blocker search found none.
struct FmFilterParams {
  ShadowMapInputs io;
  uint64_t model;  // FmModel
  uint64_t shade;  // FmShadeBlock
  uint64_t range;  // FmDepthRange
  uint64_t map;    // FmMapRecord
  uint64_t table;  // the summed-area table (doubles) or the mip chain (floats)
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::FmDepthBits) == 8);
static_assert(sizeof(penumbra::shader::FmMapRecord) == 72);
static_assert(sizeof(penumbra::shader::FmDepthRangeParams) <= 128);
static_assert(sizeof(penumbra::shader::FmEncodeParams) <= 128);
static_assert(sizeof(penumbra::shader::FmFilterParams) <= 128);
#endif

#endif  // PENUMBRA_SHADOW_FILTERED_MOMENTS_FILTERED_MOMENTS_KERNELS_SHARED_H
