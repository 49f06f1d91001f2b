#include "penumbra/shadow/multilayer/transparent_layers.h"

#include <algorithm>
#include <cmath>

namespace penumbra::multilayer {

uint32_t compress_fragments(std::span<const Fragment> fragments, const CompressionOptions& options,
                            std::vector<TransparentLayer>* out, bool* truncated) {
  // The shared compression writes at most one layer per fragment: into this thread's scratch,
  // so `out` grows only by the layers (what the memory estimates count).
  thread_local std::vector<TransparentLayer> scratch;
  if (scratch.size() < fragments.size()) scratch.resize(fragments.size());
  const shader::MlCompression o{options.error, options.resets, options.zero};
  bool dropped = false;
  const uint32_t n = shader::ml_compress_fragments(fragments.data(), 0, static_cast<uint32_t>(fragments.size()), o,
                                                   scratch.data(), 0, dropped);
  if (truncated) *truncated = dropped;
  out->insert(out->end(), scratch.begin(), scratch.begin() + n);
  return n;
}

std::vector<DepthRange> TransparentLayerMap::texel_ranges() const {
  std::vector<DepthRange> ranges(static_cast<size_t>(width) * height);
  for (size_t i = 0; i < ranges.size(); ++i) {
    if (offsets[i] == offsets[i + 1]) continue;
    ranges[i] = {layers[offsets[i]].z_first, layers[offsets[i + 1] - 1].z};
  }
  return ranges;
}

std::vector<DepthRange> TransparentLayerMap::window_ranges(const LightView& view,
                                                           std::span<const uint8_t> truncated) const {
  std::vector<DepthRange> ranges = texel_ranges();
  for (size_t i = 0; i < ranges.size(); ++i) {
    DepthRange& r = ranges[i];
    if (r.empty()) continue;
    r = {view.window_depth(r.lo), view.window_depth(r.hi)};
    if (!truncated.empty() && truncated[i]) r.hi = shader::kMlBeyondFullTexel;
  }
  return ranges;
}

}  // namespace penumbra::multilayer
