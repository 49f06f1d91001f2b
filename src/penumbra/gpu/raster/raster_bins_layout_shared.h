// The GPU rasterizer's depth-bin mode (gpu/raster/gpu_depth_bins.h): its fill's parameters, byte
// by byte. Common subset of C++ and GLSL, scalar block layout.
//   raster_fill_bins  one thread per work item (as raster_fill): every texel centre of its tile
//                     the triangle covers, alpha looked up per fragment, sets the bit of the
//                     fragment's depth bin (raster/raster_bins_shared.h; its tile's bins when
//                     the bins are per tile) in the texel's mask by atomicOr, and with `nearest`
//                     its linear depth into that bin's nearest depth by atomicMin on the float's
//                     bits (non-negative floats order as their bits do). The set-up and work
//                     items are raster_setup's.
#ifndef PENUMBRA_GPU_RASTER_RASTER_BINS_LAYOUT_SHARED_H
#define PENUMBRA_GPU_RASTER_RASTER_BINS_LAYOUT_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/gpu/raster/raster_layout_shared.h"
#include "penumbra/raster/raster_bins_shared.h"

PN_SHARED_BEGIN

// raster_fill_bins.comp's push constants, 104 bytes: raster_fill's (its `keys`: the masks, a uint
// per texel, cleared first) and the bins; with tile_bins (not 0) each tile of 2^tile_shift texels
// bins by its own record instead (RasterDepthBins[tile_columns x rows], raster_bins_tile; the
// masks' rows `width` texels wide). With `nearest` (not 0): a float per bin and texel, bin k's
// plane of `plane` texels after bin k - 1's (raster/rasterizer.h DepthBinMasks::nearest), filled
// with +infinity first.
struct RasterBinsFillParams {
  RasterFillParams fill;
  RasterDepthBins bins;
  uint64_t tile_bins;
  int tile_shift;
  int tile_columns;
  int width;
  uint plane;
  uint64_t nearest;
};

PN_SHARED_END

#ifdef __cplusplus
#include <cstddef>
static_assert(sizeof(penumbra::shader::RasterBinsFillParams) == 104 && offsetof(penumbra::shader::RasterBinsFillParams, nearest) == 96);
#endif

#endif  // PENUMBRA_GPU_RASTER_RASTER_BINS_LAYOUT_SHARED_H
