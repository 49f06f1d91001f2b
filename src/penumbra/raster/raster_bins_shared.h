// The depth bins of Rasterizer::depth_bin_masks (raster/rasterizer.h DepthBins) once for both
// devices, in the common subset of C++ and GLSL (core/shader_compat.h): which bin a fragment's
// linear depth falls in. The CPU rasterizer and the GPU's raster_fill_bins kernel call it.
#ifndef PENUMBRA_RASTER_RASTER_BINS_SHARED_H
#define PENUMBRA_RASTER_RASTER_BINS_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// Bins of linear depth, 16 bytes: bin k holds [first + k width, first + (k + 1) width), with
// inv_width = 1 / width; depths before the first bin fall into it, after the last (last =
// count - 1) into the last.
struct RasterDepthBins {
  float first;
  float inv_width;
  int last;
  uint pad;
};

PN_INLINE RasterDepthBins raster_depth_bins(float first, float width, int count) {
  RasterDepthBins b;
  b.first = first;
  b.inv_width = 1.0f / width;
  b.last = count - 1;
  b.pad = 0u;
  return b;
}

// The bin of linear depth z.
PN_INLINE int raster_depth_bin(RasterDepthBins b, float z) {
  PN_PRECISE float t = (z - b.first) * b.inv_width;
  return t <= 0.0f ? 0 : min(b.last, int(t));
}

// Which tile's bins texel (x, y) uses (DepthBins::tiles): tiles of 2^shift texels, `columns` to a
// row.
PN_INLINE uint raster_bins_tile(int x, int y, int shift, int columns) {
  return uint(y >> shift) * uint(columns) + uint(x >> shift);
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::RasterDepthBins) == 16);
#endif

#endif  // PENUMBRA_RASTER_RASTER_BINS_SHARED_H
