// The per-texel layer lists of a multilayer transparent shadow map (xie2007 §5.1): each
// light-centre ray's fragments (depth, opacity), compressed deep-shadow style into a few
// layers (z_i, v_i, count_i), and the hit rules of both multilayer maps (§4.3, §5.2, §6.1).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "penumbra/raster/fragment_lists.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/raster/minmax_pyramid.h"
#include "penumbra/shadow/multilayer/multilayer_layers_shared.h"

namespace penumbra::multilayer {

// One compressed layer (xie2007 §5.1): multilayer_layers_shared.h's record, shared with the GPU.
using TransparentLayer = shader::TransparentLayer;

struct CompressionOptions {
  // Largest deviation of the piecewise-linear visibility between control vertices from
  // the true (step) visibility of the original samples (Lokovic & Veach 2000's error bound).
  float error = 0.02f;
  // Times the accumulated visibility may reach (near) zero and restart at 1 (xie2007 §5.1):
  // the samples behind a fully opaque run can still block rays from other light points.
  int resets = 4;
  // Visibility at or below this counts as zero (a reset point).
  float zero = 1e-4f;
};

// Compresses one texel's fragments (sorted by z) into layers appended to `out`; returns how
// many it appended. Greedy deep-shadow compression: a run of samples is extended while a
// straight line from the previous control vertex to the candidate end stays within
// options.error of the visibility just before and just after every sample in the run (the
// slope-interval test of Lokovic & Veach 2000 §4.2); a run also ends where the visibility
// reaches zero, after which the visibility resets to 1 up to options.resets times.
// *truncated (when given): fragments behind the last layer were dropped (ml_compress_fragments).
uint32_t compress_fragments(std::span<const Fragment> fragments, const CompressionOptions& options,
                            std::vector<TransparentLayer>* out, bool* truncated = nullptr);

// Flat storage of every texel's layers (texel i owns layers[offsets[i], offsets[i+1])).
struct TransparentLayerMap {
  int width = 0, height = 0;
  std::vector<uint32_t> offsets;
  std::vector<TransparentLayer> layers;

  size_t index(int x, int y) const { return static_cast<size_t>(y) * width + x; }
  std::span<const TransparentLayer> at(int x, int y) const {
    size_t i = index(x, y);
    return {layers.data() + offsets[i], offsets[i + 1] - offsets[i]};
  }
  size_t memory_bytes() const {
    return offsets.size() * sizeof(uint32_t) + layers.size() * sizeof(TransparentLayer);
  }
  // Per-texel linear depth ranges [first sample, last layer].
  std::vector<DepthRange> texel_ranges() const;
  // The same in the view's window depth, for a MinMaxPyramid; a texel whose `truncated` flag is
  // set (fragments behind its last layer dropped: compress_fragments) reaching kMlBeyondFullTexel.
  // truncated: one flag per texel, or empty (not tracked: the method's unresolved=lit).
  std::vector<DepthRange> window_ranges(const LightView& view, std::span<const uint8_t> truncated) const;
};

// ---- Hit rules (xie2007 §4.3 and §6.1; multilayer_layers_shared.h): linear depths. ----

// [z - z_thresh, z + z_thresh] overlaps a ray's depth interval [lo, hi] over a texel.
using shader::layer_overlaps;

// How many of a transparent layer's `count` estimated samples (evenly spaced over
// [z_first, z]) lie in the depth interval [a, b] (xie2007 §5.2: "report a hit if the ray
// intersects with any bucket boundary"); the caller widens the ray's interval over a texel
// by z_thresh. The first of them is written to *first (when any).
inline uint32_t samples_in(const TransparentLayer& layer, float a, float b, float* first = nullptr) {
  float f = 0;
  const uint32_t n = shader::ml_samples_in(layer, a, b, f);
  if (first && n) *first = f;
  return n;
}
// The depth of estimated sample m of a layer.
inline float sample_depth(const TransparentLayer& layer, uint32_t m) { return shader::ml_sample_depth(layer, m); }

}  // namespace penumbra::multilayer
