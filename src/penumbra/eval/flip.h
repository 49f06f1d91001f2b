// FLIP, the LDR image difference evaluator of Andersson, Nilsson, Akenine-Moller,
// Oskarsson, Astrom and Fairchild, "FLIP: A Difference Evaluator for Alternating Images",
// Proc. ACM Comput. Graph. Interact. Tech. 3(2), HPG 2020 (cited "Andersson et al. 2020").
//
// Implemented from the paper's definition: a colour pipeline (opponent space,
// contrast sensitivity filters, Hunt-adjusted L*a*b*, HyAB distance, remapping to [0,1])
// and a feature pipeline (edge and point detectors on the achromatic channel), combined
// per pixel as dE = dE_c^(1 - dE_f). flip.cpp documents every constant with its source;
// docs/metrics.md the conventions and where this implementation chooses.
#pragma once

#include "penumbra/core/image.h"

namespace penumbra {

// Pixels per degree of visual angle for a monitor `width_m` metres wide showing
// `resolution_px` pixels across, seen from `distance_m` metres (Andersson et al. 2020,
// viewing conditions: p = d * (r / w) * pi / 180, the small-angle pixels per degree).
float flip_pixels_per_degree(float distance_m, float width_m, float resolution_px);

// The paper's default viewing conditions: 0.7 m from a 0.7 m wide 4K (3840 px) monitor,
// about 67.02 pixels per degree.
float flip_default_ppd();

struct FlipOptions {
  float ppd = flip_default_ppd();
  // Also return the colour and feature difference maps (dE_c, dE_f) for inspection.
  bool keep_components = false;
};

struct FlipResult {
  Image error;     // one channel, FLIP value per pixel in [0,1]
  double mean = 0; // mean of `error` over all pixels (the paper's recommended single number)
  Image color;     // dE_c per pixel, when keep_components
  Image feature;   // dE_f per pixel, when keep_components
};

// FLIP between `test` and `reference`: linear sRGB images (3 or more channels, the first
// three used; a one-channel image is grey, replicated to RGB), values clamped to [0,1]
// as the LDR evaluator assumes. Pixels outside the image are the nearest edge pixel, so
// a constant image has no edges at its border. Symmetric: flip(a, b) == flip(b, a).
// Throws Error when the sizes differ (naming both) or ppd is not positive.
FlipResult flip(const Image& test, const Image& reference, const FlipOptions& options = {});

}  // namespace penumbra
