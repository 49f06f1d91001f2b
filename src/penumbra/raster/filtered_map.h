// Prefiltered maps: "the mean of each channel over a texel-space rectangle" with a fixed
// number of reads, whatever the rectangle's size. The general part of the prefiltering that
// occlusion textures (eisemann2006 §3.2, shadow/occlusion_textures/prefilter.h) and the
// filtered-moment shadow maps (shadow/filtered_moments/: VSM, EVSM, MSM) share:
//
// - sat_box_integral(): the exact integral of a piecewise-constant texture over a rectangle
//   with real corners, from four bilinear reads of its summed-area table (Crow 1984), with
//   no large numbers cancelling for integer tables. occlusion::SatFilter (binary coverage,
//   32-bit counts or doubles) and SummedAreaTable below (any float channels, doubles) both
//   evaluate their boxes with it.
// - SummedAreaTable: a multi-channel summed-area table in double precision; box_mean() is the
//   exact box filter (16 reads per channel). What Lauritzen's summed-area variance shadow
//   maps (GPU Gems 3, ch. 8) use, in doubles instead of fp32 so that the moments' tables do
//   not lose the variance to cancellation (the chapter's precision problem).
// - MipChain: a float mip pyramid (2 x 2 means) with trilinear lookups of squares: no
//   differences of large sums at all, so channels of a huge dynamic range (EVSM's
//   exponentials, Lauritzen & McCool 2008) filter without cancellation; blockier than the
//   exact box. (occlusion::MipmapFilter stores 8-bit coverage means; its byte planes and
//   batch lookups are specific to binary slices.)
//
// Conventions as in prefilter.h and raster/light_view.h: texel (i, j) is the square
// [i, i+1) x [j, j+1), x right, y down. Outside the map every channel holds the `outside`
// values given at build (for a shadow map: the moments of an empty texel, nothing in front);
// the mean is over the whole rectangle.
#pragma once

#include <cstdint>
#include <span>
#include <type_traits>
#include <vector>

#include "penumbra/raster/filtered_map_shared.h"

namespace penumbra {

// The integral over [x0, x1] x [y0, y1] of a texture whose summed-area table is T (entry
// (x, y) = sum over [0, x) x [0, y)), from e(c, k): T at (i, j), (i+1, j), (i, j+1), (i+1, j+1)
// (k = 0..3) of corner c = (x0, y0), (x1, y0), (x0, y1), (x1, y1) (c = 0..3); (fx0, fy0),
// (fx1, fy1): the corners' fractions within their texels. Exact counts for uint32 tables
// (wrapping differences), nothing large cancelling for any (filtered_map_shared.h explains the
// arithmetic, which both devices run).
template <class Acc, class E>
Acc sat_box_integral(const E& e, Acc fx0, Acc fy0, Acc fx1, Acc fy1) {
  using Entry = std::decay_t<decltype(e(0, 0))>;
  if constexpr (std::is_same_v<Entry, uint32_t>) {
    static_assert(std::is_same_v<Acc, float>, "counts are summed in float");
    shader::SatCornersU q;
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 4; ++k) q.e[4 * c + k] = e(c, k);
    return shader::sat_box_integral_uf(q, fx0, fy0, fx1, fy1);
  } else {
    static_assert(std::is_same_v<Entry, double>, "tables hold uint32 counts or doubles");
    shader::SatCornersD q;
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 4; ++k) q.e[4 * c + k] = e(c, k);
    if constexpr (std::is_same_v<Acc, float>) return shader::sat_box_integral_df(q, fx0, fy0, fx1, fy1);
    else return shader::sat_box_integral_dd(q, fx0, fy0, fx1, fy1);
  }
}

// A width x height map of `channels` float channels, texel-interleaved (texel (x, y)'s
// channel c at texels[(y * width + x) * channels + c]).
struct ChannelImage {
  int width = 0, height = 0, channels = 0;
  std::span<const float> texels;
};

class SummedAreaTable {
 public:
  static constexpr int kMaxChannels = 4;
  void build(const ChannelImage& image, std::span<const float> outside);
  // What build() holds for such a map (for memory estimates).
  static uint64_t bytes(int width, int height, int channels) {
    return (static_cast<uint64_t>(width) + 1) * (static_cast<uint64_t>(height) + 1) * static_cast<uint64_t>(channels) *
           sizeof(double);
  }
  size_t memory_bytes() const { return data_.size() * sizeof(double); }
  int channels() const { return channels_; }
  // out[c] = the mean of channel c over [x0, x1] x [y0, y1] (x0 <= x1, y0 <= y1; a rectangle
  // of zero area reads as its point's texel).
  void box_mean(double x0, double y0, double x1, double y1, double* out) const;
  // The table as the shared lookups read it (filtered_map_shared.h: channels interleaved).
  const double* data() const { return data_.data(); }
  shader::SatTableLayout layout() const;
  const shader::FilteredChannels& outside() const { return outside_; }

 private:
  int width_ = 0, height_ = 0, channels_ = 0;
  size_t stride_ = 0;  // entries per row: (width + 1) * channels
  shader::FilteredChannels outside_{};
  std::vector<double> data_;
};

class MipChain {
 public:
  static constexpr int kMaxChannels = 4;
  // Level 0 is the map padded with `outside` to a power-of-two square.
  void build(const ChannelImage& image, std::span<const float> outside);
  static uint64_t bytes(int width, int height, int channels);
  size_t memory_bytes() const;
  int levels() const { return view_.levels; }
  // out[c] = the trilinear estimate of channel c's mean over the square of side `side`
  // texels centred on (cx, cy): level log2(side), bilinear within the two levels around it.
  void square_mean(float cx, float cy, float side, double* out) const;
  // out[c] = channel c's mean over [x0, x1] x [y0, y1]: at the two levels around the level
  // of detail log2(longer side / 4), the mean of a grid of bilinear taps one texel of that
  // level apart (4 to 8 along the longer side), blended by the fractional level (as a GPU's
  // trilinear filter). One trilinear tap's tent is twice the box it stands for and blurs
  // penumbrae (MAE 0.03-0.04 against the exact box on the tests' scenes); the tap grid comes
  // within a few texels of the box.
  void box_mean(float x0, float y0, float x1, float y1, double* out) const;
  // The levels as the shared lookups read them (filtered_map_shared.h: one array, level after
  // level).
  const float* texels() const { return texels_.data(); }
  const shader::MipChainView& view() const { return view_; }

 private:
  shader::MipChainView view_{};
  std::vector<float> texels_;  // every level, level 0 first
};

}  // namespace penumbra
