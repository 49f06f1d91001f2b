// What the depth modes of the rasterizer produce: the nearest surface per texel (DepthMap)
// and the k nearest distinct surfaces per texel (LayeredDepthMap, xie2007 §4.2). Texel
// (x, y) follows the LightView conventions (row 0 at the top, sampled at its centre).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "penumbra/core/math.h"

namespace penumbra {

// Triangle index of an empty texel or layer.
inline constexpr uint32_t kNoTriangle = 0xffffffffu;

// One surface seen through a texel centre.
struct DepthSample {
  float z = kInfinity;        // linear depth (LightView), world units
  float depth = kInfinity;    // window depth in [0, 1]
  float opacity = 0;          // of the surface; for a merged layer, 1 - prod(1 - opacity_i)
  uint32_t triangle = kNoTriangle;  // index into the rasterized triangle list
};

// The nearest surface per texel, stored as planes (one array per quantity) so a method or a
// pyramid can read the one it needs. Empty texels hold z = depth = +inf, opacity 0 and
// kNoTriangle.
struct DepthMap {
  int width = 0, height = 0;
  std::vector<float> z;          // linear depth
  std::vector<float> depth;      // window depth
  std::vector<float> opacity;
  std::vector<uint32_t> triangle;

  void resize(int w, int h);
  // What a w x h map holds (its four planes), for memory estimates before it exists.
  static uint64_t bytes(int w, int h) {
    return static_cast<uint64_t>(w) * static_cast<uint64_t>(h) * (3 * sizeof(float) + sizeof(uint32_t));
  }
  size_t index(int x, int y) const { return static_cast<size_t>(y) * width + x; }
  bool covered(int x, int y) const { return triangle[index(x, y)] != kNoTriangle; }
  DepthSample at(int x, int y) const {
    size_t i = index(x, y);
    return {z[i], depth[i], opacity[i], triangle[i]};
  }
};

// Up to `max_layers` distinct surfaces per texel, nearest first (xie2007 §4.2). Stored
// texel-major: a texel's layers are contiguous, which is what a walk that scans all layers
// of one texel reads (xie2007 §4.3). Only the first counts[i] samples of texel i are
// meaningful (layers() returns exactly those); the rasterizer does not clear the rest.
struct LayeredDepthMap {
  int width = 0, height = 0;
  int max_layers = 0;
  std::vector<uint8_t> counts;        // layers present per texel
  std::vector<DepthSample> samples;   // width * height * max_layers

  void resize(int w, int h, int layers);
  // What a w x h map of `layers` layers holds: every slot is allocated, used or not.
  static uint64_t bytes(int w, int h, int layers) {
    const uint64_t texels = static_cast<uint64_t>(w) * static_cast<uint64_t>(h);
    return texels * (sizeof(uint8_t) + static_cast<uint64_t>(layers) * sizeof(DepthSample));
  }
  size_t index(int x, int y) const { return static_cast<size_t>(y) * width + x; }
  int count(int x, int y) const { return counts[index(x, y)]; }
  std::span<const DepthSample> layers(int x, int y) const {
    size_t i = index(x, y);
    return {samples.data() + i * max_layers, counts[i]};
  }
};

}  // namespace penumbra
