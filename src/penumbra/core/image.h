// Image buffers: a width x height grid of pixels with C float channels, row-major,
// row 0 at the top (as written to files).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/math.h"

namespace penumbra {

class Image {
 public:
  Image() = default;
  Image(int width, int height, int channels, float fill = 0.0f)
      : width_(width), height_(height), channels_(channels),
        data_(static_cast<size_t>(width) * height * channels, fill) {}
  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  size_t pixel_count() const { return static_cast<size_t>(width_) * height_; }
  bool empty() const { return data_.empty(); }
  float& at(int x, int y, int c = 0) { return data_[(static_cast<size_t>(y) * width_ + x) * channels_ + c]; }
  float at(int x, int y, int c = 0) const { return data_[(static_cast<size_t>(y) * width_ + x) * channels_ + c]; }
  float* pixel(size_t i) { return &data_[i * channels_]; }
  const float* pixel(size_t i) const { return &data_[i * channels_]; }
  Vec3f rgb(size_t i) const { const float* p = pixel(i); return channels_ >= 3 ? Vec3f(p[0], p[1], p[2]) : Vec3f(p[0]); }
  void set_rgb(size_t i, Vec3f c) { float* p = pixel(i); p[0] = c.x; p[1] = c.y; p[2] = c.z; }
  std::vector<float>& data() { return data_; }
  const std::vector<float>& data() const { return data_; }
  // A single-channel copy of channel c.
  Image channel(int c) const;

 private:
  int width_ = 0, height_ = 0, channels_ = 0;
  std::vector<float> data_;
};

// Linear -> sRGB transfer (IEC 61966-2-1), clamped to [0,1].
float linear_to_srgb(float v);
float srgb_to_linear(float v);

// Writes by extension: .exr (linear half/float, channels R,G,B and optional extra named
// channels) or .png (sRGB 8-bit; 1-channel images are written as grey, linear values
// passed through the sRGB curve unless `linear_png` is set). The file is written to a
// temporary name in the same folder and renamed, so a failed write leaves nothing.
struct NamedChannel {
  std::string name;
  const Image* image;  // single channel, same size
};
void write_image(const std::string& path, const Image& rgb_or_grey,
                 const std::vector<NamedChannel>& extra = {}, bool linear_png = false);

// An 8-bit PNG in memory: 1-channel images as grey, 3+ channels as RGB. Values are linear
// and pass through the sRGB curve unless `linear` (then they are written as they are,
// clamped to [0,1]): the bytes write_image() writes to a .png file.
std::vector<unsigned char> encode_png(const Image& image, bool linear = false);
// The 8-bit values encode_png stores: sRGB-encoded (clamped to [0,1] when `linear`),
// `channels` per pixel: 1 (the first channel), 3 (RGB; grey repeated) or 4 (RGB, alpha 255).
std::vector<unsigned char> to_8bit(const Image& image, int channels, bool linear = false);

// Reads .exr (the R,G,B channels, or Y/V when it has one channel) or .png/.jpg (sRGB
// decoded to linear unless `linear_png`). Errors name the file.
Image read_image(const std::string& path, bool linear_png = false);
// Reads one named channel of an EXR file (e.g. "V"); throws if it is absent.
Image read_exr_channel(const std::string& path, const std::string& channel);

}  // namespace penumbra
