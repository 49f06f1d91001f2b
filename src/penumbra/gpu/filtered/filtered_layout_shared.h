// The GPU's prefiltered maps (gpu/filtered/gpu_filtered_map.h): the kernels' parameters, byte by
// byte. The tables and chains they build have raster/filtered_map_shared.h's layouts (the CPU's
// SummedAreaTable, MipChain and occlusion SatFilter), so the shared lookups read either. Common
// subset of C++ and GLSL (core/shader_compat.h), scalar block layout.
//
// A summed-area table is built in two kernels, with the CPU's additions in the CPU's order (its
// doubles are the CPU's bit for bit):
//   sat_scan_rows     one thread per (row, channel): the running sum along the row into the
//                     table's next row (row y + 1; the thread of row 0 also zeroes table row 0);
//   sat_scan_columns  one thread per (table column, channel): each row adds the row above, top
//                     to bottom.
// A mip chain in two: mip_level0 (one thread per texel of the padded square: the map or the
// outside value) and mip_reduce (one thread per texel of the next level: the mean of 2 x 2).
#ifndef PENUMBRA_GPU_FILTERED_FILTERED_LAYOUT_SHARED_H
#define PENUMBRA_GPU_FILTERED_FILTERED_LAYOUT_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/filtered_map_shared.h"

PN_SHARED_BEGIN

// Where a table's values come from.
PN_CONST uint kSatSourceFloats = 0u;  // float[height][width][channels]: channel c of texel (x, y)
PN_CONST uint kSatSourceBits = 1u;    // uint[height][width]: channel c is bit c of the texel's word (0 or 1)
// What a table's entries are.
PN_CONST uint kSatEntriesDouble = 0u;
PN_CONST uint kSatEntriesUint = 1u;  // exact counts (kSatSourceBits only), wrapping as the CPU's do

// sat_scan_rows.comp and sat_scan_columns.comp, 48 bytes.
struct SatBuildParams {
  uint64_t source;  // see kSatSource*
  uint64_t table;   // double or uint entries, layout
  SatTableLayout table_layout;
  uint source_kind;
  uint entry_kind;
};

// mip_level0.comp: level 0, side x side, from a width x height float image (channels
// interleaved), the outside values beyond it. 64 bytes.
struct MipLevel0Params {
  uint64_t source;  // float[height][width][channels]
  uint64_t texels;  // the chain (MipChainView's layout)
  int width;
  int height;
  int side;
  int channels;
  float outside[4];
  uint pad0;
  uint pad1;
  uint pad2;
  uint pad3;
};

// mip_reduce.comp: level l + 1 (side `side`) from level l, 24 bytes.
struct MipReduceParams {
  uint64_t texels;
  uint fine_offset;    // level l's first float
  uint coarse_offset;  // level l + 1's
  int side;            // level l + 1's side
  int channels;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::SatBuildParams) == 48);
static_assert(sizeof(penumbra::shader::MipLevel0Params) == 64);
static_assert(sizeof(penumbra::shader::MipReduceParams) == 24);
#endif

#endif  // PENUMBRA_GPU_FILTERED_FILTERED_LAYOUT_SHARED_H
