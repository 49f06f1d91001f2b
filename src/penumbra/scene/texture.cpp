#include "penumbra/scene/texture.h"
#include "penumbra/scene/texture_shared.h"

#include <stb_image.h>
#include <stb_image_write.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <limits>
#include <memory>

#include "penumbra/core/error.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/image.h"

namespace penumbra {

namespace fs = std::filesystem;

const char* to_string(AlphaMode m) {
  switch (m) {
    case AlphaMode::Opaque: return "opaque";
    case AlphaMode::Mask: return "mask";
    case AlphaMode::Blend: return "blend";
  }
  return "?";
}

Texture::Texture(int width, int height, std::vector<float> rgba, bool has_alpha, std::string name)
    : width_(width), height_(height), has_alpha_(has_alpha), rgba_(std::move(rgba)), name_(std::move(name)) {
  if (width <= 0 || height <= 0 || rgba_.size() != static_cast<size_t>(width) * height * 4)
    throw Error("texture {}: {}x{} texels need {} floats, got {}", name_, width, height,
                static_cast<size_t>(std::max(width, 0)) * std::max(height, 0) * 4, rgba_.size());
}

namespace {

// 8-bit texels (1 to 4 channels) to linear RGBA floats.
std::shared_ptr<const Texture> from_8bit(const unsigned char* data, int w, int h, int n, Texture::Encoding encoding,
                                         const std::string& name) {
  // The sRGB decode of the 256 possible values, once.
  static const auto srgb = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) t[i] = srgb_to_linear(i / 255.0f);
    return t;
  }();
  const size_t texels = static_cast<size_t>(w) * h;
  std::vector<float> rgba(texels * 4);
  const bool alpha = n == 2 || n == 4;
  const int colours = n >= 3 ? 3 : 1;
  for (size_t i = 0; i < texels; ++i) {
    const unsigned char* p = data + i * n;
    for (int c = 0; c < 3; ++c) {
      unsigned char v = p[colours == 3 ? c : 0];
      rgba[4 * i + c] = encoding == Texture::Encoding::Srgb ? srgb[v] : v / 255.0f;
    }
    rgba[4 * i + 3] = alpha ? p[n - 1] / 255.0f : 1.0f;
  }
  return std::make_shared<const Texture>(w, h, std::move(rgba), alpha, name);
}

// Larger images are refused before they are decoded: 8192^2 texels are 1 GiB of floats.
constexpr int kMaxSide = 8192;
void check_size(int w, int h, const std::string& name) {
  if (w > kMaxSide || h > kMaxSide)
    throw Error("{}: a {}x{} image; textures are read up to {}x{}", name, w, h, kMaxSide, kMaxSide);
}

std::string lower_extension(const fs::path& p) {
  std::string ext = p.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace

std::shared_ptr<const Texture> Texture::decode(std::span<const unsigned char> bytes, Encoding encoding,
                                               const std::string& name) {
  if (bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max()))
    throw Error("{}: image too large ({} bytes)", name, bytes.size());
  int w = 0, h = 0, n = 0;
  if (stbi_info_from_memory(bytes.data(), static_cast<int>(bytes.size()), &w, &h, &n)) check_size(w, h, name);
  unsigned char* data = stbi_load_from_memory(bytes.data(), static_cast<int>(bytes.size()), &w, &h, &n, 0);
  if (!data) throw Error("{}: cannot read image: {}", name, stbi_failure_reason());
  std::unique_ptr<unsigned char, void (*)(void*)> guard(data, stbi_image_free);
  return from_8bit(data, w, h, n, encoding, name);
}

std::shared_ptr<const Texture> Texture::load(const fs::path& path, Encoding encoding) {
  const std::string name = path.string();
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error("{}: no such file", name);
  if (fs::is_directory(path, ec)) throw Error("{}: is a folder, not an image", name);
  if (!fs::is_regular_file(path, ec)) throw Error("{}: not a regular file", name);
  if (lower_extension(path) == ".exr") {
    // Linear floats: RGB (or one channel as grey), no alpha.
    Image img = read_image(name);
    std::vector<float> rgba(img.pixel_count() * 4, 1.0f);
    for (size_t i = 0; i < img.pixel_count(); ++i) {
      Vec3f c = img.rgb(i);
      rgba[4 * i] = c.x, rgba[4 * i + 1] = c.y, rgba[4 * i + 2] = c.z;
    }
    return std::make_shared<const Texture>(img.width(), img.height(), std::move(rgba), false, name);
  }
  int w = 0, h = 0, n = 0;
  if (stbi_info(name.c_str(), &w, &h, &n)) check_size(w, h, name);
  unsigned char* data = stbi_load(name.c_str(), &w, &h, &n, 0);
  if (!data) throw Error("{}: cannot read image: {}", name, stbi_failure_reason());
  std::unique_ptr<unsigned char, void (*)(void*)> guard(data, stbi_image_free);
  return from_8bit(data, w, h, n, encoding, name);
}

Texture::Footprint Texture::footprint(Vec2f uv) const {
  // texture_shared.h: the lookup the GPU kernels make too.
  const shader::TexelFootprint t = shader::texel_footprint(uv, width_, height_);
  return Footprint{{t.i0, t.i1, t.i2, t.i3}, {t.w0, t.w1, t.w2, t.w3}};
}

Vec3f Texture::rgb(Vec2f uv) const {
  const Footprint f = footprint(uv);
  Vec3f c(0.0f);
  for (int k = 0; k < 4; ++k) {
    const float* t = &rgba_[4 * f.i[k]];
    c = c + Vec3f(t[0], t[1], t[2]) * f.w[k];
  }
  return c;
}

float Texture::alpha(Vec2f uv) const {
  const Footprint f = footprint(uv);
  const int channel = has_alpha_ ? 3 : 0;
  float a = 0;
  for (int k = 0; k < 4; ++k) a += rgba_[4 * f.i[k] + channel] * f.w[k];
  return a;
}

float SurfaceAlpha::mean_opacity(const Vec2f uv[3], int n) const {
  if (!active()) return 1.0f;
  // Cell centres of an n x n grid on the unit square, folded onto the triangle (b1 + b2 <= 1).
  double sum = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      float b1 = (i + 0.5f) / n, b2 = (j + 0.5f) / n;
      if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
      const float b0 = 1 - b1 - b2;
      sum += opacity({b0 * uv[0].x + b1 * uv[1].x + b2 * uv[2].x, b0 * uv[0].y + b1 * uv[1].y + b2 * uv[2].y});
    }
  return static_cast<float>(sum / (static_cast<double>(n) * n));
}

void Texture::write_png(const std::string& path) const {
  const size_t texels = static_cast<size_t>(width_) * height_;
  const int channels = has_alpha_ ? 4 : 3;
  std::vector<unsigned char> bytes(texels * channels);
  for (size_t i = 0; i < texels; ++i) {
    for (int c = 0; c < 3; ++c)
      bytes[channels * i + c] = static_cast<unsigned char>(std::lround(linear_to_srgb(rgba_[4 * i + c]) * 255.0f));
    if (has_alpha_) bytes[4 * i + 3] = static_cast<unsigned char>(std::lround(clamp01(rgba_[4 * i + 3]) * 255.0f));
  }
  std::vector<unsigned char> png;
  auto sink = [](void* ctx, void* data, int size) {
    auto* out = static_cast<std::vector<unsigned char>*>(ctx);
    out->insert(out->end(), static_cast<unsigned char*>(data), static_cast<unsigned char*>(data) + size);
  };
  if (!stbi_write_png_to_func(sink, &png, width_, height_, channels, bytes.data(), width_ * channels))
    throw Error("{}: cannot encode a {}x{} texture", path, width_, height_);
  write_text_file_atomic(path, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

}  // namespace penumbra
