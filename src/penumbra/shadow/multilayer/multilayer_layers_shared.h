// The layers of a multilayer transparent shadow map (xie2007 §5.1) in the common subset of C++
// and GLSL (core/shader_compat.h): the compressed layer's record, the deep-shadow compression of
// one texel's sorted fragments, and the hit rules of both multilayer maps (§4.3, §5.2, §6.1).
// The CPU's map builder and trace (transparent_layers.h, multilayer_trace.cpp) and the GPU's
// kernels (kernels/mtsm_compress.comp, mlsm_trace.comp, mtsm_trace.comp) call these functions.
#ifndef PENUMBRA_SHADOW_MULTILAYER_MULTILAYER_LAYERS_SHARED_H
#define PENUMBRA_SHADOW_MULTILAYER_MULTILAYER_LAYERS_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// One compressed layer, 24 bytes (also the GPU's record): the `count` original samples between
// the previous control vertex and this one (xie2007 §5.1).
//   bytes 0-3 z_first: depth of the first of them (the paper infers it from z_{i-1}; storing it
//             places the count estimated samples evenly over [z_first, z] exactly where the run
//             starts, for 4 bytes a layer)
//   bytes 4-7 z: depth of the last (the control vertex)
//   bytes 8-11 v: accumulated visibility after the layer (since the last reset)
//   bytes 12-15 transmit: per-sample transmittance (v / v_before)^(1 / count) that one crossing
//             of one estimated sample multiplies in (eq. 3 applied multiplicatively, so a ray
//             crossing some samples of a run and not others is attenuated by exactly those)
//   bytes 16-19 count   20-23 triangle: the last sample's (the rasterizer's list)
struct TransparentLayer {
  float z_first;
  float z;
  float v;
  float transmit;
  uint count;
  uint triangle;
};

// One fragment of a texel's sorted list, 12 bytes (penumbra::Fragment, the GPU's fragment
// lists: gpu/raster/raster_fragments_shared.h): linear depth, opacity, input triangle.
struct MlFragment {
  float z;
  float opacity;
  uint triangle;
};

// The compression's settings (CompressionOptions).
struct MlCompression {
  float error;  // largest deviation of the compressed visibility from the original
  int resets;   // times the visibility may reach zero and restart at 1
  float zero;   // visibility at or below this counts as zero
};

PN_INLINE float ml_inf() { return uintBitsToFloat(0x7f800000u); }

PN_SHARED_END

// Where the compression reads a texel's fragments and writes its layers: in C++ pointers, in
// GLSL buffer references.
#ifdef __cplusplus
#include <cmath>

#include "penumbra/raster/fragment_lists.h"
namespace penumbra::shader {
using MlFragmentsRef = const penumbra::Fragment*;
using MlLayersOut = TransparentLayer*;
inline MlFragment ml_fragment(MlFragmentsRef f, uint i) { return {f[i].z, f[i].opacity, f[i].triangle}; }
inline void ml_put_layer(MlLayersOut layers, uint i, TransparentLayer l) { layers[i] = l; }
// std::pow and std::ceil in float, as the CPU computed them before they were shared.
inline float ml_pow(float a, float b) { return std::pow(a, b); }
inline float ml_ceil(float x) { return std::ceil(x); }
}  // namespace penumbra::shader
#else
layout(buffer_reference, scalar) readonly buffer MlFragmentsRef { MlFragment v[]; };
layout(buffer_reference, scalar) buffer MlLayersOut { TransparentLayer v[]; };
MlFragment ml_fragment(MlFragmentsRef f, uint i) { return f.v[i]; }
void ml_put_layer(MlLayersOut layers, uint i, TransparentLayer l) { layers.v[i] = l; }
float ml_pow(float a, float b) { return pow(a, b); }
float ml_ceil(float x) { return ceil(x); }
#endif

PN_SHARED_BEGIN

// Full texels (penumbra's addition; multilayer.md "Rays the map cannot answer for"): a texel of
// the k-layer map that holds k layers (xie2007 §4.2: the k nearest, the rest dropped), or of the
// transparent map whose visibility reached zero once more than its resets allow (§5.1: the
// fragments behind dropped; ml_compress_fragments' truncated), does not know what lies behind its
// last layer. With the method's unresolved=trace the top of its range in the pyramid's level 0
// is this window depth (multilayer_map.cpp, mlsm_layer_ranges.comp, mtsm_compress.comp): a ray
// behind its last layer is walked to the texel instead of skipped as behind every surface, and
// the leaf tests tell it there (multilayer_trace_shared.h, ml_behind_full_texel).
PN_CONST float kMlBeyondFullTexel = 1e30f;

// Compresses fragments[first, first + n) (sorted by z) into layers written at out[out_first ..];
// returns how many (at most n). Greedy deep-shadow compression: a run of samples is extended
// while a straight line from the previous control vertex to the candidate end stays within
// o.error of the visibility just before and just after every sample in the run (the
// slope-interval test of Lokovic & Veach 2000 §4.2); a run also ends where the visibility
// reaches zero, after which the visibility resets to 1 up to o.resets times. truncated: the
// visibility reached zero once more than o.resets allow with fragments left behind, dropped (what
// lies behind the last layer is unknown: multilayer_trace_shared.h, kMlBeyondFullTexel).
PN_INLINE uint ml_compress_fragments(MlFragmentsRef fragments, uint first, uint n, MlCompression o, MlLayersOut layers,
                                     uint out_first, PN_OUT(bool) truncated) {
  truncated = false;
  uint written = 0u;
  int resets_left = o.resets;
  uint i = 0u;
  float v_epoch = 1.0f;  // accumulated visibility since the last reset
  while (i < n) {
    // A run [i, j]: its control vertex is at fragment j. The line runs from (z0, v0), the point
    // just before fragment i at visibility v_epoch.
    MlFragment fi = ml_fragment(fragments, first + i);
    float z0 = fi.z;
    float v0 = v_epoch;
    PN_PRECISE float v = v0 * (1.0f - fi.opacity);
    float slope_lo = -ml_inf();  // allowed slopes dv/dz of the line from (z0, v0)
    float slope_hi = ml_inf();
    uint j = i;
    uint triangle = fi.triangle;
    float z_last = fi.z;
    // Visibility just before and after each sample of the run must be within error of the line.
    while (v > o.zero && j + 1u < n) {
      MlFragment f = ml_fragment(fragments, first + j + 1u);
      PN_PRECISE float v_after = v * (1.0f - f.opacity);
      PN_PRECISE float dz = f.z - z0;
      float lo = slope_lo;
      float hi = slope_hi;
      bool ok = true;
      if (!(dz <= 0.0f)) {
        // The line must end exactly at (f.z, v_after) (the new control vertex)...
        PN_PRECISE float s = (v_after - v0) / dz;
        ok = s >= slope_lo && s <= slope_hi;
        // ...and pass within error of the visibility just before f.
        PN_PRECISE float lo_f = (v - o.error - v0) / dz;
        PN_PRECISE float hi_f = (v + o.error - v0) / dz;
        lo = lo < lo_f ? lo_f : lo;  // std::max
        hi = hi_f < hi ? hi_f : hi;  // std::min
        ok = ok && s >= lo - 1e-12f && s <= hi + 1e-12f;
      }
      // (dz <= 0: coincident with the run's first sample; the line cannot tell them apart: merge.)
      if (!ok) break;
      // Accept f: tighten the slope interval by the visibility after f (for later ends).
      if (dz > 0.0f) {
        PN_PRECISE float lo_a = (v_after - o.error - v0) / dz;
        PN_PRECISE float hi_a = (v_after + o.error - v0) / dz;
        slope_lo = lo < lo_a ? lo_a : lo;
        slope_hi = hi_a < hi ? hi_a : hi;
      }
      v = v_after;
      j += 1u;
      triangle = f.triangle;
      z_last = f.z;
    }
    TransparentLayer layer;
    layer.z_first = z0;
    layer.z = z_last;
    layer.count = j - i + 1u;
    layer.v = v;
    layer.triangle = triangle;
    float ratio = v_epoch > 0.0f ? v / v_epoch : 0.0f;
    layer.transmit = ratio <= 0.0f ? 0.0f : ml_pow(ratio, 1.0f / float(layer.count));
    ml_put_layer(layers, out_first + written, layer);
    written += 1u;
    i = j + 1u;
    v_epoch = v;
    if (v_epoch <= o.zero) {
      if (resets_left <= 0) {  // nothing behind can be seen through any more
        truncated = i < n;
        break;
      }
      resets_left -= 1;
      v_epoch = 1.0f;
    }
  }
  return written;
}

// ---- Hit rules (xie2007 §4.3 and §6.1): all depths are linear (light-view) depths. ----

// A ray whose depth over a texel is [lo, hi] (lo <= hi) hits an opaque layer at depth z when
// [z - z_thresh, z + z_thresh] overlaps it.
PN_INLINE bool layer_overlaps(float z, float z_thresh, float lo, float hi) {
  return z - z_thresh <= hi && lo <= z + z_thresh;
}

// How many of a transparent layer's `count` estimated samples (evenly spaced over [z_first, z])
// lie in the depth interval [a, b] (xie2007 §5.2: "report a hit if the ray intersects with any
// bucket boundary"). The first of them is written to first (when any).
PN_INLINE uint ml_samples_in(TransparentLayer layer, float a, float b, PN_OUT(float) first) {
  first = 0.0f;
  if (!(a <= b) || layer.z < a || layer.z_first > b) return 0u;
  if (layer.count <= 1u) {
    first = layer.z;
    return 1u;
  }
  // Samples at z_first + m * step, m = 0 .. count - 1.
  PN_PRECISE float step = (layer.z - layer.z_first) / float(layer.count - 1u);
  if (!(step > 0.0f)) {  // all at one depth, and that depth is in [a, b]
    first = layer.z;
    return layer.count;
  }
  float m_lo = max(0.0f, ml_ceil((a - layer.z_first) / step));
  float m_hi = min(float(layer.count - 1u), floor((b - layer.z_first) / step));
  if (!(m_hi >= m_lo)) return 0u;
  PN_PRECISE float f = layer.z_first + m_lo * step;
  first = f;
  return uint(m_hi - m_lo) + 1u;
}

// The depth of estimated sample m of a layer.
PN_INLINE float ml_sample_depth(TransparentLayer layer, uint m) {
  PN_PRECISE float z = layer.z_first + (layer.z - layer.z_first) * (float(m) / float(layer.count - 1u));
  return layer.count <= 1u ? layer.z : z;
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::TransparentLayer) == 24);
static_assert(sizeof(penumbra::shader::MlFragment) == 12);
static_assert(sizeof(penumbra::Fragment) == 12);
#endif

#endif  // PENUMBRA_SHADOW_MULTILAYER_MULTILAYER_LAYERS_SHARED_H
