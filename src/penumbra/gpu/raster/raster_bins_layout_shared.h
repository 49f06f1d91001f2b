// The GPU rasterizer's depth-bin mode (gpu/raster/gpu_depth_bins.h): its fill's parameters, byte
// by byte. Common subset of C++ and GLSL, scalar block layout.
//   raster_fill_bins  one thread per work item (as raster_fill): every texel centre of its tile
//                     the triangle covers, alpha looked up per fragment, sets the bit of the
//                     fragment's depth bin (raster/raster_bins_shared.h; its tile's bins when
//                     the bins are per tile) in the texel's mask by atomicOr. The set-up and
//                     work items are raster_setup's.
#ifndef PENUMBRA_GPU_RASTER_RASTER_BINS_LAYOUT_SHARED_H
#define PENUMBRA_GPU_RASTER_RASTER_BINS_LAYOUT_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/gpu/raster/raster_layout_shared.h"
#include "penumbra/raster/raster_bins_shared.h"

PN_SHARED_BEGIN

// raster_fill_bins.comp's push constants, 104 bytes: raster_fill's (its `keys`: the masks, a uint
// per texel, cleared first) and the bins; with tile_bins (not 0) each tile of 2^tile_shift texels
// bins by its own record instead (RasterDepthBins[tile_columns x rows], raster_bins_tile; the
// masks' rows `width` texels wide).
struct RasterBinsFillParams {
  RasterFillParams fill;
  RasterDepthBins bins;
  uint64_t tile_bins;
  int tile_shift;
  int tile_columns;
  int width;
  uint pad;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::RasterBinsFillParams) <= 128);
#endif

#endif  // PENUMBRA_GPU_RASTER_RASTER_BINS_LAYOUT_SHARED_H
