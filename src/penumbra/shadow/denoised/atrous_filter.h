// The spatial part of SVGF (Schied et al. 2017, §4.2-4.3): an edge-aware a-trous wavelet
// filter over a screen-space image, guided by depth and normal, with a luminance weight
// scaled by the signal's own variance. Here the signal is a shadow ratio (Heitz et al. 2018,
// "Combining analytic direct illumination and stochastic shadows", §3): the stochastic
// shadowed estimate S and the stochastic unshadowed estimate U of the same light samples are
// filtered with the same weights, and V = filtered S / filtered U multiplies the analytic
// unshadowed irradiance. The per-pixel arithmetic is atrous_shared.h's, which the GPU version
// runs too. docs/methods/rt-denoised.md.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/shadow/denoised/atrous_shared.h"
#include "penumbra/shadow/params.h"

namespace penumbra::denoise {

// One screen-space image of width x height pixels; pixels with `valid` 0 (no surface: the
// background, or no camera ray of this layer) take no part in the filter.
struct GuidedImage {
  int width = 0, height = 0;
  std::vector<uint8_t> valid;
  std::vector<float> depth;    // linear view depth
  std::vector<Vec3f> normal;   // unit shading normal
  std::vector<float> shadowed;    // S = sum_i T_i f_i / N
  std::vector<float> unshadowed;  // U = sum_i f_i / N
  // A = sum_i T_i a_i / sum_i a_i: the fraction of the light's area the point sees (samples
  // behind a closed receiver's tangent plane blocked), filtered with S and U; V, and the
  // luminance guide where U is 0 (the point faces away from the light).
  std::vector<float> area;
  std::vector<float> variance;  // Var(S / U) of the pixel's estimate (filtered along, §4.2)

  void resize(int w, int h);
  size_t index(int x, int y) const { return static_cast<size_t>(y) * width + x; }
  // The irradiance ratio S / U (A where U is 0), clamped to [0, 1].
  float ratio(size_t i) const;
  // V: the area fraction A, clamped to [0, 1].
  float visibility(size_t i) const;
  // The planes as the shared functions read them (atrous_shared.h; valid while the image is
  // not resized).
  shader::DenoiseImage shared() const;
  // Bytes resize() allocates per pixel.
  static constexpr uint64_t kBytesPerPixel = 1 + 6 * sizeof(float) + sizeof(Vec3f);
};

struct AtrousSettings {
  int iterations = 5;     // §4.2: 5 iterations, step 2^i
  float sigma_z = 1.0f;   // §4.3 eq. 3: depth
  float sigma_n = 128.0f; // §4.3 eq. 4: normal exponent
  float sigma_l = 4.0f;   // §4.3 eq. 5: luminance (here: V)
};

// The settings of rt-denoised's parameters (denoised.cpp's table: iterations, sigma_z, sigma_n,
// sigma_l), for both devices' versions.
AtrousSettings atrous_settings_from(const ParamSet& p);

// §4.1: below this many samples per pixel, the pixel's own sample variance is replaced by
// the spatial estimate (SVGF uses it for histories shorter than 4 frames).
inline constexpr int kMinSamplesForOwnVariance = 4;

// §4.1's fallback for short histories: where a pixel holds fewer than 4 samples its own
// sample variance says nothing, so the variance is estimated spatially as the variance of V
// over a 7x7 neighbourhood, bilaterally weighted by depth and normal (w_z w_n). Overwrites
// img.variance.
void estimate_variance_spatially(GuidedImage& img, const AtrousSettings& s);

// Runs s.iterations a-trous passes (§4.2) over S, U, A and the variance, in place. Deterministic;
// parallel over rows. Extra bytes it allocates per pixel: kScratchBytesPerPixel.
void atrous_filter(GuidedImage& img, const AtrousSettings& s);
inline constexpr uint64_t kScratchBytesPerPixel = 5 * sizeof(float) + 2 * sizeof(float);

}  // namespace penumbra::denoise
