// The layered depth map's rule for distinct surfaces (xie2007 §4.2; Rasterizer::layered_depth_map,
// LayerOptions::distinct_epsilon) in the common subset of C++ and GLSL (core/shader_compat.h):
// the CPU inserts each fragment into its texel's sorted list by it, the GPU peels layer after
// layer by it (gpu/raster/gpu_rasterizer_layers.cpp), and both group a texel's fragments the same
// way: from the front, a fragment starts a new layer when it lies more than epsilon behind the
// current layer's front (its nearest fragment), otherwise it joins that layer.
#ifndef PENUMBRA_RASTER_RASTER_LAYERS_SHARED_H
#define PENUMBRA_RASTER_RASTER_LAYERS_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// Whether a fragment at linear depth z lies behind the layer whose front is at `front` as a
// distinct surface (more than epsilon behind it). A fragment with z >= front for which this is
// false joins that layer.
PN_INLINE bool raster_layer_behind(float z, float front, float epsilon) { return z - front > epsilon; }

// A joined fragment's opacity composed into its layer's: what a ray crossing both coincident
// sheets keeps, 1 - (1 - a)(1 - b).
PN_INLINE float raster_layer_opacity(float layer, float fragment) { return 1.0f - (1.0f - layer) * (1.0f - fragment); }

PN_SHARED_END

#endif  // PENUMBRA_RASTER_RASTER_LAYERS_SHARED_H
