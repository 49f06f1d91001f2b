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
  std::copy(outside.begin(), outside.end(), outside_);
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

void SummedAreaTable::box_mean(double x0, double y0, double x1, double y1, double* out) const {
  const double area = (x1 - x0) * (y1 - y0);
  if (!(area > 0)) {  // a point: its texel (or outside)
    const double xm = std::floor(x0), ym = std::floor(y0);
    x0 = xm, y0 = ym, x1 = xm + 1, y1 = ym + 1;
    return box_mean(x0, y0, x1, y1, out);
  }
  const double cx0 = std::max(x0, 0.0), cy0 = std::max(y0, 0.0);
  const double cx1 = std::min(x1, double(width_)), cy1 = std::min(y1, double(height_));
  const double inside = cx1 > cx0 && cy1 > cy0 ? (cx1 - cx0) * (cy1 - cy0) : 0.0;
  // The part outside the map holds the outside values.
  for (int c = 0; c < channels_; ++c) out[c] = outside_[c] * (area - inside) / area;
  if (inside == 0) return;
  const int i0 = std::min(static_cast<int>(cx0), width_ - 1), i1 = std::min(static_cast<int>(cx1), width_ - 1);
  const int j0 = std::min(static_cast<int>(cy0), height_ - 1), j1 = std::min(static_cast<int>(cy1), height_ - 1);
  const size_t C = channels_;
  const double* corner[4] = {data_.data() + j0 * stride_ + i0 * C, data_.data() + j0 * stride_ + i1 * C,
                             data_.data() + j1 * stride_ + i0 * C, data_.data() + j1 * stride_ + i1 * C};
  const size_t offset[4] = {0, C, stride_, stride_ + C};
  for (size_t c = 0; c < C; ++c) {
    const double integral = sat_box_integral<double>([&](int k, int o) { return corner[k][offset[o] + c]; },
                                                      cx0 - i0, cy0 - j0, cx1 - i1, cy1 - j1);
    out[c] += integral / area;
  }
}

uint64_t MipChain::bytes(int width, int height, int channels) {
  const uint64_t side = std::bit_ceil(static_cast<uint64_t>(std::max({width, height, 1})));
  // Levels side^2 + side^2/4 + ... < 4/3 side^2.
  return side * side * 4 / 3 * static_cast<uint64_t>(channels) * sizeof(float) + 64;
}

size_t MipChain::memory_bytes() const {
  size_t n = 0;
  for (const Level& l : levels_) n += l.texels.size() * sizeof(float);
  return n;
}

void MipChain::build(const ChannelImage& image, std::span<const float> outside) {
  if (image.channels < 1 || image.channels > kMaxChannels || outside.size() != static_cast<size_t>(image.channels))
    throw Error("MipChain: 1 to 4 channels, with as many outside values");
  channels_ = image.channels;
  std::copy(outside.begin(), outside.end(), outside_);
  const int C = channels_;
  const int side = static_cast<int>(std::bit_ceil(static_cast<unsigned>(std::max({image.width, image.height, 1}))));
  levels_.clear();
  levels_.push_back({side, std::vector<float>(static_cast<size_t>(side) * side * C)});
  Level& base = levels_[0];
  parallel_for(static_cast<size_t>(side), 16, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y)
      for (int x = 0; x < side; ++x)
        for (int c = 0; c < C; ++c)
          base.texels[(y * side + x) * C + c] =
              static_cast<int>(y) < image.height && x < image.width
                  ? image.texels[(y * static_cast<size_t>(image.width) + x) * C + c]
                  : outside_[c];
  });
  for (int s = side / 2; s >= 1; s /= 2) {
    levels_.push_back({s, std::vector<float>(static_cast<size_t>(s) * s * C)});
    const Level& fine = levels_[levels_.size() - 2];
    Level& coarse = levels_.back();
    parallel_for(static_cast<size_t>(s), 16, [&](size_t y0, size_t y1) {
      for (size_t y = y0; y < y1; ++y)
        for (int x = 0; x < s; ++x)
          for (int c = 0; c < C; ++c) {
            const size_t a = ((2 * y) * fine.side + 2 * x) * C + c, b = a + static_cast<size_t>(fine.side) * C;
            coarse.texels[(y * s + x) * C + c] =
                0.25f * ((fine.texels[a] + fine.texels[a + C]) + (fine.texels[b] + fine.texels[b + C]));
          }
    });
  }
}

void MipChain::bilinear(int level, float x, float y, double* out) const {
  const Level& l = levels_[level];
  const float scale = 1.0f / static_cast<float>(1 << level);
  // Texel centres at (i + 0.5) in level units.
  const float u = x * scale - 0.5f, v = y * scale - 0.5f;
  const int i = static_cast<int>(std::floor(u)), j = static_cast<int>(std::floor(v));
  const float fx = u - static_cast<float>(i), fy = v - static_cast<float>(j);
  const float w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  const int xs[4] = {i, i + 1, i, i + 1}, ys[4] = {j, j, j + 1, j + 1};
  for (int c = 0; c < channels_; ++c) out[c] = 0;
  for (int k = 0; k < 4; ++k) {
    const bool in = xs[k] >= 0 && ys[k] >= 0 && xs[k] < l.side && ys[k] < l.side;
    const float* t = in ? &l.texels[(static_cast<size_t>(ys[k]) * l.side + xs[k]) * channels_] : outside_;
    for (int c = 0; c < channels_; ++c) out[c] += static_cast<double>(w[k]) * t[c];
  }
}

void MipChain::square_mean(float cx, float cy, float side, double* out) const {
  const float lod = std::clamp(std::log2(std::max(side, 1.0f)), 0.0f, static_cast<float>(levels() - 1));
  const int l0 = static_cast<int>(lod), l1 = std::min(l0 + 1, levels() - 1);
  const float f = lod - static_cast<float>(l0);
  double a[kMaxChannels], b[kMaxChannels];
  bilinear(l0, cx, cy, a);
  if (f > 0 && l1 != l0) {
    bilinear(l1, cx, cy, b);
    for (int c = 0; c < channels_; ++c) out[c] = a[c] + (b[c] - a[c]) * f;
  } else {
    for (int c = 0; c < channels_; ++c) out[c] = a[c];
  }
}

void MipChain::box_mean(float x0, float y0, float x1, float y1, double* out) const {
  constexpr int kTaps = 4;
  const float sx = std::max(x1 - x0, 0.0f), sy = std::max(y1 - y0, 0.0f);
  const float longer = std::max({sx, sy, 1.0f});
  // The level of detail, continuous (as a GPU's trilinear filter), so that the estimate
  // changes smoothly with the rectangle's size rather than jumping between levels.
  const float lod = std::clamp(std::log2(longer / kTaps), 0.0f, static_cast<float>(levels() - 1));
  const int l0 = static_cast<int>(lod), l1 = std::min(l0 + 1, levels() - 1);
  const float f = lod - static_cast<float>(l0);
  double tap[kMaxChannels], at[2][kMaxChannels];
  for (int k = 0; k < (f > 0 && l1 != l0 ? 2 : 1); ++k) {
    const int level = k == 0 ? l0 : l1;
    const float cell = static_cast<float>(1 << level);
    const int nx = std::clamp(static_cast<int>(std::ceil(sx / cell)), 1, 2 * kTaps);
    const int ny = std::clamp(static_cast<int>(std::ceil(sy / cell)), 1, 2 * kTaps);
    for (int c = 0; c < channels_; ++c) at[k][c] = 0;
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        bilinear(level, x0 + sx * (static_cast<float>(i) + 0.5f) / static_cast<float>(nx),
                 y0 + sy * (static_cast<float>(j) + 0.5f) / static_cast<float>(ny), tap);
        for (int c = 0; c < channels_; ++c) at[k][c] += tap[c];
      }
    for (int c = 0; c < channels_; ++c) at[k][c] /= nx * ny;
  }
  for (int c = 0; c < channels_; ++c) out[c] = f > 0 && l1 != l0 ? at[0][c] + (at[1][c] - at[0][c]) * f : at[0][c];
}

}  // namespace penumbra
