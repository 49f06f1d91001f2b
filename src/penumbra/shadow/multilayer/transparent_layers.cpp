#include "penumbra/shadow/multilayer/transparent_layers.h"

#include <algorithm>
#include <cmath>

namespace penumbra::multilayer {

uint32_t compress_fragments(std::span<const Fragment> fragments, const CompressionOptions& options,
                            std::vector<TransparentLayer>* out) {
  const size_t n = fragments.size();
  const size_t start_size = out->size();
  int resets_left = options.resets;
  size_t i = 0;
  float v_epoch = 1.0f;  // accumulated visibility since the last reset
  while (i < n) {
    // A run [i, j]: its control vertex is at fragment j. The line runs from (z_prev, v_prev),
    // the previous control vertex (or, for the first run after a reset, the point just
    // before fragment i at visibility v_epoch).
    const float z0 = fragments[i].z;
    const float v0 = v_epoch;
    float v = v0 * (1.0f - fragments[i].opacity);
    float slope_lo = -kInfinity, slope_hi = kInfinity;  // allowed slopes dv/dz of the line from (z0, v0)
    size_t j = i;
    // Visibility just before and after each sample of the run must be within error of the line.
    while (v > options.zero && j + 1 < n) {
      const Fragment& f = fragments[j + 1];
      const float v_after = v * (1.0f - f.opacity);
      const float dz = f.z - z0;
      // Constraints of sample j (already in the run) and the candidate end j+1.
      float lo = slope_lo, hi = slope_hi;
      bool ok = true;
      if (dz <= 0) {
        // Coincident with the run's first sample: the line cannot tell them apart; merge.
        ok = true;
      } else {
        // The line must end exactly at (f.z, v_after) (the new control vertex).
        const float s = (v_after - v0) / dz;
        ok = s >= slope_lo && s <= slope_hi;
        // And pass within error of the visibility just before f.
        lo = std::max(lo, (v - options.error - v0) / dz);
        hi = std::min(hi, (v + options.error - v0) / dz);
        ok = ok && s >= lo - 1e-12f && s <= hi + 1e-12f;
      }
      if (!ok) break;
      // Accept f: tighten the slope interval by the visibility after f (for later ends).
      if (dz > 0) {
        slope_lo = std::max(lo, (v_after - options.error - v0) / dz);
        slope_hi = std::min(hi, (v_after + options.error - v0) / dz);
      }
      v = v_after;
      ++j;
    }
    TransparentLayer layer;
    layer.z_first = fragments[i].z;
    layer.z = fragments[j].z;
    layer.count = static_cast<uint32_t>(j - i + 1);
    layer.v = v;
    layer.triangle = fragments[j].triangle;
    const float ratio = v_epoch > 0 ? v / v_epoch : 0.0f;
    layer.transmit = ratio <= 0 ? 0.0f : std::pow(ratio, 1.0f / static_cast<float>(layer.count));
    out->push_back(layer);
    i = j + 1;
    v_epoch = v;
    if (v_epoch <= options.zero) {
      if (resets_left-- <= 0) break;  // nothing behind can be seen through any more
      v_epoch = 1.0f;
    }
  }
  return static_cast<uint32_t>(out->size() - start_size);
}

std::vector<DepthRange> TransparentLayerMap::texel_ranges() const {
  std::vector<DepthRange> ranges(static_cast<size_t>(width) * height);
  for (size_t i = 0; i < ranges.size(); ++i) {
    if (offsets[i] == offsets[i + 1]) continue;
    ranges[i] = {layers[offsets[i]].z_first, layers[offsets[i + 1] - 1].z};
  }
  return ranges;
}

uint32_t samples_in(const TransparentLayer& layer, float a, float b, float* first) {
  if (!(a <= b) || layer.z < a || layer.z_first > b) return 0;
  if (layer.count <= 1) {
    if (first) *first = layer.z;
    return 1;
  }
  // Samples at z_first + m * step, m = 0 .. count - 1.
  const float step = (layer.z - layer.z_first) / static_cast<float>(layer.count - 1);
  if (!(step > 0)) {  // all at one depth, and that depth is in [a, b]
    if (first) *first = layer.z;
    return layer.count;
  }
  const float m_lo = std::max(0.0f, std::ceil((a - layer.z_first) / step));
  const float m_hi = std::min(static_cast<float>(layer.count - 1), std::floor((b - layer.z_first) / step));
  if (!(m_hi >= m_lo)) return 0;
  if (first) *first = layer.z_first + m_lo * step;
  return static_cast<uint32_t>(m_hi - m_lo) + 1;
}

}  // namespace penumbra::multilayer
