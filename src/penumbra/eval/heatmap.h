// Error maps as colour images: absolute errors with a perceptual sequential colour map
// (magma: black -> purple -> orange -> light yellow) and signed errors with a diverging
// map (blue for negative, white at 0, red for positive). The value range a colour stands
// for is returned with the image, so a report can print the scale beside it.
#pragma once

#include <string>

#include "penumbra/core/image.h"
#include "penumbra/core/math.h"

namespace penumbra {

enum class ColorMap {
  kMagma,     // sequential, perceptually uniform (van der Walt & Smith, matplotlib, CC0)
  kDiverging  // blue - white - red (ColorBrewer RdBu end colours, white centre)
};

struct Heatmap {
  Image image;  // RGB, linear: write_image(".png") shows the colour map's sRGB colours
  ColorMap map = ColorMap::kMagma;
  float lo = 0;  // value shown as the first colour (and below it: clamped)
  float hi = 1;  // value shown as the last colour (and above it: clamped)
  // E.g. "magma: 0 (black) .. 0.25 (light yellow)" or
  // "diverging: -0.1 (blue) .. 0 (white) .. 0.1 (red)".
  std::string legend() const;
};

// Colour of t in [0,1] (clamped) on the map, as sRGB-encoded (display) values in [0,1].
// For kDiverging t = 0.5 is the centre (white).
Vec3f colormap_srgb(ColorMap map, float t);

// |values| on [0, scale] with a sequential map (kMagma). `values` has one channel (use
// difference_map() or a FLIP error map). scale <= 0 picks the largest |value| (1 when
// every value is 0), so the brightest colour marks the largest error. NaN values are
// pure green in both maps.
Heatmap absolute_heatmap(const Image& values, float scale = 0);

// values on [-scale, scale] with the diverging map: negative (test darker than the
// reference) blue, zero white, positive red. scale <= 0 picks the largest |value| (1 when
// every value is 0), symmetric so that white always means "no error".
Heatmap signed_heatmap(const Image& values, float scale = 0);

}  // namespace penumbra
