#include "penumbra/eval/heatmap.h"

#include <algorithm>
#include <cmath>
#include <span>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra {

namespace {

struct Stop {
  float t;
  Vec3f srgb;
};

// magma (Stefan van der Walt and Nathaniel Smith, matplotlib / BIDS colormap, CC0): its
// 256-entry table sampled every 16 entries plus the last, positions index / 255.
// Linear interpolation between these 17 stops stays within about 2/255 of the full table.
constexpr Stop kMagma[] = {
    {0.0f / 255, {0.001462f, 0.000466f, 0.013866f}},
    {16.0f / 255, {0.039608f, 0.031090f, 0.133515f}},
    {32.0f / 255, {0.113094f, 0.065492f, 0.276784f}},
    {48.0f / 255, {0.211718f, 0.061992f, 0.418647f}},
    {64.0f / 255, {0.316654f, 0.071690f, 0.485380f}},
    {80.0f / 255, {0.414709f, 0.110431f, 0.504662f}},
    {96.0f / 255, {0.512831f, 0.148179f, 0.507648f}},
    {112.0f / 255, {0.613617f, 0.181811f, 0.498536f}},
    {128.0f / 255, {0.716387f, 0.214982f, 0.475290f}},
    {144.0f / 255, {0.816914f, 0.255895f, 0.436461f}},
    {160.0f / 255, {0.904281f, 0.319610f, 0.388137f}},
    {176.0f / 255, {0.960949f, 0.418323f, 0.359630f}},
    {192.0f / 255, {0.986700f, 0.535582f, 0.382210f}},
    {208.0f / 255, {0.996096f, 0.653659f, 0.446213f}},
    {224.0f / 255, {0.996898f, 0.769591f, 0.534892f}},
    {240.0f / 255, {0.992440f, 0.884330f, 0.640099f}},
    {255.0f / 255, {0.987053f, 0.991438f, 0.749504f}},
};

// Diverging blue - white - red: ColorBrewer RdBu (5 classes) #0571b0 #92c5de . #f4a582
// #ca0020, with pure white at the centre so that "no error" is exactly white.
constexpr Stop kDiverging[] = {
    {0.00f, {0.019608f, 0.443137f, 0.690196f}},
    {0.25f, {0.572549f, 0.772549f, 0.870588f}},
    {0.50f, {1.0f, 1.0f, 1.0f}},
    {0.75f, {0.956863f, 0.647059f, 0.509804f}},
    {1.00f, {0.792157f, 0.0f, 0.125490f}},
};

Vec3f interpolate(std::span<const Stop> stops, float t) {
  t = std::isnan(t) ? 0.0f : clamp01(t);
  size_t k = 1;
  while (k + 1 < stops.size() && stops[k].t < t) ++k;
  const Stop &a = stops[k - 1], &b = stops[k];
  float u = clamp01((t - a.t) / (b.t - a.t));
  return lerp(u, a.srgb, b.srgb);
}

constexpr Vec3f kNanColor = {0.0f, 1.0f, 0.0f};

std::string format_value(float v) { return fmt::format("{:.4g}", v); }

void check_single(const Image& values, const char* what) {
  if (values.channels() != 1)
    throw Error("{} needs a one-channel error map, got {} channels (use difference_map)", what,
                values.channels());
}

float auto_scale(const Image& values) {
  float m = 0;
  for (float v : values.data())
    if (std::isfinite(v)) m = std::max(m, std::abs(v));
  return m > 0 ? m : 1.0f;
}

Heatmap colorize(const Image& values, ColorMap map, float lo, float hi) {
  Heatmap hm;
  hm.map = map;
  hm.lo = lo;
  hm.hi = hi;
  hm.image = Image(values.width(), values.height(), 3);
  const float inv = 1.0f / (hi - lo);
  parallel_for(values.pixel_count(), 4096, [&](size_t i0, size_t i1) {
    for (size_t i = i0; i < i1; ++i) {
      float v = values.data()[i];
      if (map == ColorMap::kMagma) v = std::abs(v);
      // NaN is pure green, a colour neither map contains, so broken pixels stand out.
      Vec3f c = std::isnan(v) ? kNanColor : colormap_srgb(map, (v - lo) * inv);
      // Store linear values: write_image encodes PNGs with the sRGB curve, which gives
      // back the map's colours.
      hm.image.set_rgb(i, {srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z)});
    }
  });
  return hm;
}

}  // namespace

Vec3f colormap_srgb(ColorMap map, float t) {
  return map == ColorMap::kMagma ? interpolate(kMagma, t) : interpolate(kDiverging, t);
}

std::string Heatmap::legend() const {
  if (map == ColorMap::kMagma)
    return fmt::format("magma: {} (black) .. {} (light yellow)", format_value(lo),
                       format_value(hi));
  return fmt::format("diverging: {} (blue) .. {} (white) .. {} (red)", format_value(lo),
                     format_value(0.5f * (lo + hi)), format_value(hi));
}

Heatmap absolute_heatmap(const Image& values, float scale) {
  check_single(values, "absolute_heatmap");
  if (!(scale > 0)) scale = auto_scale(values);
  return colorize(values, ColorMap::kMagma, 0.0f, scale);
}

Heatmap signed_heatmap(const Image& values, float scale) {
  check_single(values, "signed_heatmap");
  if (!(scale > 0)) scale = auto_scale(values);
  return colorize(values, ColorMap::kDiverging, -scale, scale);
}

}  // namespace penumbra
