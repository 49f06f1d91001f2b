// Images on surfaces: a material's base-colour and alpha textures (issue 20), looked up by
// texture coordinates. Alpha-masked foliage is the case agrawala2000 and xie2007 show off:
// a leaf is a quad whose texture says where the leaf is.
//
// Conventions (those of OBJ, OpenGL and Assimp, which flips glTF's v on import): texture
// coordinates (0, 0) are the image's bottom-left corner, (1, 1) its top-right; coordinates
// outside [0, 1) repeat. Lookups are bilinear between texel centres (the GPU's default and
// glTF's usual sampler), so a two-valued checkerboard thresholded at 0.5 has its edges exactly
// on the texel borders.
#pragma once

#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "penumbra/core/math.h"

namespace penumbra {

enum class AlphaMode {
  Opaque,  // the texture's alpha is ignored
  Mask,    // glTF MASK, OBJ map_d: the surface is there where alpha >= alpha_cutoff, else a hole
  Blend,   // glTF BLEND: alpha is the surface's fractional opacity (xie2007 §5)
};
const char* to_string(AlphaMode m);

class Texture {
 public:
  // How 8-bit colour channels are stored: base-colour images are sRGB-encoded (glTF, OBJ's
  // practice), masks and other data are linear. Alpha is always linear; float images (EXR)
  // always hold linear values.
  enum class Encoding { Srgb, Linear };

  Texture() = default;
  // rgba: width x height texels of 4 linear floats, row 0 at the top. has_alpha: whether the
  // image had an alpha channel (alpha() then reads it, otherwise the first channel: a grey
  // mask image).
  Texture(int width, int height, std::vector<float> rgba, bool has_alpha, std::string name = {});

  // Reads a PNG, JPEG, TGA or BMP file (stb_image) or an EXR file, up to 8192 x 8192 texels.
  // Errors name the file (missing, not a regular file, unreadable, too large).
  static std::shared_ptr<const Texture> load(const std::filesystem::path& path, Encoding encoding);
  // The same from an image file's bytes (a glTF file's embedded image); `name` for messages.
  static std::shared_ptr<const Texture> decode(std::span<const unsigned char> bytes, Encoding encoding,
                                               const std::string& name);

  int width() const { return width_; }
  int height() const { return height_; }
  bool has_alpha() const { return has_alpha_; }
  const std::string& name() const { return name_; }  // the file it came from, for messages
  const std::vector<float>& rgba() const { return rgba_; }

  // Bilinear lookups at texture coordinates uv.
  Vec3f rgb(Vec2f uv) const;
  // The alpha channel, or the first channel of an image without one.
  float alpha(Vec2f uv) const;

  // Writes the texture as an 8-bit PNG, RGBA (or RGB without alpha): sRGB colour, linear
  // alpha. What the foliage generator's leaf image looks like on disk. Atomic like write_image.
  void write_png(const std::string& path) const;

 private:
  // The four texels around uv and their weights.
  struct Footprint {
    size_t i[4];
    float w[4];
  };
  Footprint footprint(Vec2f uv) const;

  int width_ = 0, height_ = 0;
  bool has_alpha_ = false;
  std::vector<float> rgba_;
  std::string name_;
};

// What decides whether a point of a surface is there, and how much light it stops: the alpha
// part of a Material, shared by every method (ray tracer filter, rasterizer, BVH queries).
struct SurfaceAlpha {
  std::shared_ptr<const Texture> texture;  // non-null when mode != Opaque
  AlphaMode mode = AlphaMode::Opaque;
  float cutoff = 0.5f;

  bool active() const { return mode != AlphaMode::Opaque && texture != nullptr; }
  // The opacity factor at uv: mask 1 or 0 (alpha >= cutoff), blend alpha in [0, 1], opaque 1.
  float opacity(Vec2f uv) const {
    if (!active()) return 1.0f;
    float a = texture->alpha(uv);
    if (mode == AlphaMode::Mask) return a >= cutoff ? 1.0f : 0.0f;
    return std::min(1.0f, std::max(0.0f, a));
  }
  // The mean of opacity() over the triangle with corner coordinates uv[3] (n x n stratified
  // points): the per-triangle approximation for methods that cannot look a texture up per
  // ray (single-sample's cone queries).
  float mean_opacity(const Vec2f uv[3], int n = 16) const;
  // Whether a camera ray stops at uv: a mask's hole lets it through; a blend surface is seen
  // where its alpha reaches the cutoff (the renderer shades one surface per ray, so a blend
  // surface is either seen or not; its shadow keeps the fractional alpha).
  bool seen(Vec2f uv) const {
    if (!active()) return true;
    return texture->alpha(uv) >= cutoff;
  }
};

}  // namespace penumbra
