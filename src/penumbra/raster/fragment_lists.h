// Per-texel lists of every fragment (surface crossing) through each texel centre, with its
// opacity: the input of deep shadow maps and multilayer transparent shadow maps (xie2007 §5).
// Flat storage (sintorn2008 §3: counts, prefix sum, scatter) instead of a vector per texel.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace penumbra {

struct Fragment {
  float z = 0;           // linear depth (LightView), world units
  float opacity = 1;     // RasterTriangle::opacity
  uint32_t triangle = 0; // index into the rasterized triangle list
};

// Texel i = y * width + x owns fragments[offsets[i], offsets[i + 1]), sorted by z (ties by
// triangle index, so the order does not depend on the thread count).
struct FragmentLists {
  int width = 0, height = 0;
  std::vector<uint32_t> offsets;  // width * height + 1 prefix sums
  std::vector<Fragment> fragments;

  size_t index(int x, int y) const { return static_cast<size_t>(y) * width + x; }
  uint32_t count(int x, int y) const {
    size_t i = index(x, y);
    return offsets[i + 1] - offsets[i];
  }
  std::span<const Fragment> at(int x, int y) const {
    size_t i = index(x, y);
    return {fragments.data() + offsets[i], offsets[i + 1] - offsets[i]};
  }
  size_t total() const { return fragments.size(); }
};

}  // namespace penumbra
