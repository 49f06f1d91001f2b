#include "penumbra/raster/filtered_map.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra {

void SummedAreaTable::build(const ChannelImage& image, std::span<const float> outside) {
  if (image.channels < 1 || image.channels > kMaxChannels || outside.size() != static_cast<size_t>(image.channels))
    throw Error("SummedAreaTable: 1 to 4 channels, with as many outside values");
  width_ = image.width;
  height_ = image.height;
  channels_ = image.channels;
  outside_ = {};
  for (int c = 0; c < channels_; ++c) outside_.v[c] = outside[c];
  stride_ = (static_cast<size_t>(width_) + 1) * channels_;
  data_.assign(stride_ * (static_cast<size_t>(height_) + 1), 0.0);
  // Row sums first (rows are independent), then the columns' running sums (columns are):
  // the same additions in the same order whatever the thread count.
  const int C = channels_;
  parallel_for(static_cast<size_t>(height_), 16, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y) {
      const float* src = image.texels.data() + y * static_cast<size_t>(width_) * C;
      double* row = data_.data() + (y + 1) * stride_;
      for (int c = 0; c < C; ++c) row[c] = 0;
      for (int x = 0; x < width_; ++x)
        for (int c = 0; c < C; ++c) row[(x + 1) * C + c] = row[x * C + c] + src[x * C + c];
    }
  });
  parallel_for(stride_, 256, [&](size_t i0, size_t i1) {
    for (int y = 1; y <= height_; ++y) {
      double* row = data_.data() + static_cast<size_t>(y) * stride_;
      const double* above = row - stride_;
      for (size_t i = i0; i < i1; ++i) row[i] += above[i];
    }
  });
}

shader::SatTableLayout SummedAreaTable::layout() const {
  const uint32_t C = static_cast<uint32_t>(channels_);
  return {width_, height_, channels_, C, static_cast<uint32_t>(stride_), 1u};
}

void SummedAreaTable::box_mean(double x0, double y0, double x1, double y1, double* out) const {
  const shader::FilteredChannels m = shader::sat_box_mean(data_.data(), layout(), outside_, x0, y0, x1, y1);
  std::copy(m.v, m.v + channels_, out);
}

uint64_t MipChain::bytes(int width, int height, int channels) {
  const uint64_t side = std::bit_ceil(static_cast<uint64_t>(std::max({width, height, 1})));
  // Levels side^2 + side^2/4 + ... < 4/3 side^2.
  return side * side * 4 / 3 * static_cast<uint64_t>(channels) * sizeof(float) + 64;
}

size_t MipChain::memory_bytes() const { return texels_.size() * sizeof(float); }

void MipChain::build(const ChannelImage& image, std::span<const float> outside) {
  if (image.channels < 1 || image.channels > kMaxChannels || outside.size() != static_cast<size_t>(image.channels))
    throw Error("MipChain: 1 to 4 channels, with as many outside values");
  const int C = image.channels;
  const int side = static_cast<int>(std::bit_ceil(static_cast<unsigned>(std::max({image.width, image.height, 1}))));
  view_ = {};
  view_.side = side;
  view_.levels = std::bit_width(static_cast<unsigned>(side));
  view_.channels = C;
  std::copy(outside.begin(), outside.end(), view_.outside);
  texels_.assign(shader::mip_level_offset(side, C, view_.levels), 0.0f);
  float* base = texels_.data();
  parallel_for(static_cast<size_t>(side), 16, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y)
      for (int x = 0; x < side; ++x)
        for (int c = 0; c < C; ++c)
          base[(y * side + x) * C + c] = static_cast<int>(y) < image.height && x < image.width
                                             ? image.texels[(y * static_cast<size_t>(image.width) + x) * C + c]
                                             : view_.outside[c];
  });
  for (int l = 1; l < view_.levels; ++l) {
    const int s = side >> l, fine_side = side >> (l - 1);
    const float* fine = texels_.data() + shader::mip_level_offset(side, C, l - 1);
    float* coarse = texels_.data() + shader::mip_level_offset(side, C, l);
    parallel_for(static_cast<size_t>(s), 16, [&](size_t y0, size_t y1) {
      for (size_t y = y0; y < y1; ++y)
        for (int x = 0; x < s; ++x)
          for (int c = 0; c < C; ++c) {
            const size_t a = ((2 * y) * fine_side + 2 * x) * C + c, b = a + static_cast<size_t>(fine_side) * C;
            coarse[(y * s + x) * C + c] = 0.25f * ((fine[a] + fine[a + C]) + (fine[b] + fine[b + C]));
          }
    });
  }
}

void MipChain::square_mean(float cx, float cy, float side, double* out) const {
  const float lod = std::clamp(std::log2(std::max(side, 1.0f)), 0.0f, static_cast<float>(levels() - 1));
  const int l0 = static_cast<int>(lod), l1 = std::min(l0 + 1, levels() - 1);
  const float f = lod - static_cast<float>(l0);
  const shader::FilteredChannels a = shader::mip_bilinear(texels_.data(), view_, l0, cx, cy);
  const shader::FilteredChannels b =
      f > 0 && l1 != l0 ? shader::mip_bilinear(texels_.data(), view_, l1, cx, cy) : a;
  for (int c = 0; c < view_.channels; ++c) out[c] = a.v[c] + (b.v[c] - a.v[c]) * f;
}

void MipChain::box_mean(float x0, float y0, float x1, float y1, double* out) const {
  const shader::FilteredChannels m = shader::mip_box_mean(texels_.data(), view_, x0, y0, x1, y1);
  std::copy(m.v, m.v + view_.channels, out);
}

}  // namespace penumbra
