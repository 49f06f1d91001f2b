#include "penumbra/core/image.h"

#include "penumbra/core/file_util.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include <ImfArray.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfPixelType.h>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STBI_WRITE_NO_STDIO_CONVERSION
#include <stb_image_write.h>
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#include <stb_image.h>

namespace penumbra {

namespace fs = std::filesystem;

Image Image::channel(int c) const {
  Image out(width_, height_, 1);
  for (size_t i = 0; i < pixel_count(); ++i) out.data()[i] = pixel(i)[c];
  return out;
}

float linear_to_srgb(float v) {
  v = clamp01(v);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

float srgb_to_linear(float v) {
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (auto& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return ext;
}

void write_exr(const std::string& path, const Image& img, const std::vector<NamedChannel>& extra) {
  const int w = img.width(), h = img.height();
  Imf::Header header(w, h);
  Imf::FrameBuffer fb;
  const size_t xs = sizeof(float) * img.channels(), ys = xs * w;
  char* base = reinterpret_cast<char*>(const_cast<float*>(img.data().data()));
  if (img.channels() >= 3) {
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c) {
      header.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
      fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys));
    }
  } else {
    header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
    fb.insert("Y", Imf::Slice(Imf::FLOAT, base, xs, ys));
  }
  for (const auto& ch : extra) {
    if (ch.image->width() != w || ch.image->height() != h || ch.image->channels() != 1)
      throw Error("{}: channel {} does not match the image size", path, ch.name);
    header.channels().insert(ch.name, Imf::Channel(Imf::FLOAT));
    char* b = reinterpret_cast<char*>(const_cast<float*>(ch.image->data().data()));
    fb.insert(ch.name, Imf::Slice(Imf::FLOAT, b, sizeof(float), sizeof(float) * w));
  }
  AtomicFile out(path);
  try {
    Imf::OutputFile file(out.tmp().c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(h);
  } catch (const std::exception& e) {
    throw Error("{}: cannot write EXR: {}", path, e.what());
  }
  out.commit();
}

void write_png(const std::string& path, const Image& img, bool linear) {
  const std::vector<unsigned char> png = encode_png(img, linear);
  write_text_file_atomic(path, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

}  // namespace

std::vector<unsigned char> to_8bit(const Image& img, int channels, bool linear) {
  std::vector<unsigned char> bytes(img.pixel_count() * channels, 255);
  const int colours = std::min(channels, 3);
  for (size_t i = 0; i < img.pixel_count(); ++i)
    for (int c = 0; c < colours; ++c) {
      float v = img.pixel(i)[img.channels() >= 3 ? c : 0];
      float e = linear ? clamp01(v) : linear_to_srgb(v);
      bytes[i * channels + c] = static_cast<unsigned char>(std::lround(e * 255.0f));
    }
  return bytes;
}

std::vector<unsigned char> encode_png(const Image& img, bool linear) {
  const int w = img.width(), h = img.height();
  if (w <= 0 || h <= 0) throw Error("encode_png: empty image");
  const int comp = img.channels() >= 3 ? 3 : 1;
  const std::vector<unsigned char> bytes = to_8bit(img, comp, linear);
  std::vector<unsigned char> png;
  auto sink = [](void* ctx, void* data, int size) {
    auto* out = static_cast<std::vector<unsigned char>*>(ctx);
    const auto* d = static_cast<const unsigned char*>(data);
    out->insert(out->end(), d, d + size);
  };
  if (!stbi_write_png_to_func(sink, &png, w, h, comp, bytes.data(), w * comp))
    throw Error("encode_png: cannot encode a {}x{} image", w, h);
  return png;
}

void write_image(const std::string& path, const Image& img, const std::vector<NamedChannel>& extra,
                 bool linear_png) {
  if (img.empty()) throw Error("{}: refusing to write an empty image", path);
  fs::path parent = fs::path(path).parent_path();
  if (!parent.empty() && !fs::is_directory(parent))
    throw Error("{}: folder {} does not exist", path, parent.string());
  std::string ext = lower_extension(path);
  if (ext == ".exr") return write_exr(path, img, extra);
  if (ext == ".png") return write_png(path, img, linear_png);
  throw Error("{}: unknown image extension '{}' (use .exr or .png)", path, ext);
}

Image read_exr_channel(const std::string& path, const std::string& channel) {
  try {
    Imf::InputFile file(path.c_str());
    Imath::Box2i dw = file.header().dataWindow();
    int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
    if (!file.header().channels().findChannel(channel))
      throw Error("{}: no channel '{}'", path, channel);
    Image img(w, h, 1);
    Imf::FrameBuffer fb;
    char* base = reinterpret_cast<char*>(img.data().data()) -
                 (static_cast<ptrdiff_t>(dw.min.x) + static_cast<ptrdiff_t>(dw.min.y) * w) * sizeof(float);
    fb.insert(channel, Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * w));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    return img;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error("{}: cannot read EXR: {}", path, e.what());
  }
}

Image read_image(const std::string& path, bool linear_png) {
  if (!fs::exists(path)) throw Error("{}: no such file", path);
  std::string ext = lower_extension(path);
  if (ext == ".exr") {
    Imf::InputFile probe(path.c_str());
    const auto& chans = probe.header().channels();
    if (chans.findChannel("R") && chans.findChannel("G") && chans.findChannel("B")) {
      Image r = read_exr_channel(path, "R"), g = read_exr_channel(path, "G"), b = read_exr_channel(path, "B");
      Image out(r.width(), r.height(), 3);
      for (size_t i = 0; i < out.pixel_count(); ++i) out.set_rgb(i, {r.data()[i], g.data()[i], b.data()[i]});
      return out;
    }
    for (const char* name : {"Y", "V"})
      if (chans.findChannel(name)) return read_exr_channel(path, name);
    throw Error("{}: EXR has neither R,G,B nor a Y or V channel", path);
  }
  if (ext == ".png" || ext == ".jpg" || ext == ".jpeg") {
    int w, h, n;
    unsigned char* data = stbi_load(path.c_str(), &w, &h, &n, 0);
    if (!data) throw Error("{}: cannot read image: {}", path, stbi_failure_reason());
    std::unique_ptr<unsigned char, void (*)(void*)> guard(data, stbi_image_free);
    int comp = n >= 3 ? 3 : 1;
    Image out(w, h, comp);
    for (size_t i = 0; i < out.pixel_count(); ++i)
      for (int c = 0; c < comp; ++c) {
        float v = data[i * n + c] / 255.0f;
        out.pixel(i)[c] = linear_png ? v : srgb_to_linear(v);
      }
    return out;
  }
  throw Error("{}: unknown image extension '{}' (use .exr, .png or .jpg)", path, ext);
}

}  // namespace penumbra
