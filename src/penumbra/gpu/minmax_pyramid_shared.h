// The GPU's min/max pyramids (gpu/minmax_pyramid_gpu.h), byte by byte. Common subset of C++ and
// GLSL (core/shader_compat.h), scalar block layout.
//
// A pyramid of a width x height image is one buffer of nodes, 8 bytes each: (lo, hi) as two
// floats, an empty node (no surface) (+inf, -inf). Level 0 (the image, row-major, row 0 at the
// top) comes first, then each level l + 1 of ceil(w_l / 2) x ceil(h_l / 2) nodes right after
// level l, down to 1 x 1: raster/minmax_pyramid.h's levels, in the order
// raster/depth_image_walk_shared.h's depth_pyramid_ref reads them, with the pyramid's level table
// (DepthPyramidLevel per level: the level's first node and size).
#ifndef PENUMBRA_GPU_MINMAX_PYRAMID_SHARED_H
#define PENUMBRA_GPU_MINMAX_PYRAMID_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// minmax_pyramid_reduce.comp's push constants: one level from the one below it.
struct MinMaxPyramidReduceParams {
  uint64_t nodes;     // the pyramid's buffer
  uint child_offset;  // first node of the level below (in nodes)
  uint parent_offset;
  int child_width;
  int child_height;
  int parent_width;
  int parent_height;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::MinMaxPyramidReduceParams) == 32);
#endif

#endif  // PENUMBRA_GPU_MINMAX_PYRAMID_SHARED_H
