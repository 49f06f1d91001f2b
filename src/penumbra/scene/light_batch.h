// Many light samples toward one shading point at once, in structure-of-arrays form, for the
// loops that draw 64-1024 samples per point (the `reference` ground truth and every method
// that samples the light per point). The warps of the spherical rectangle (Urena et al. 2013)
// and of the cone toward a sphere run as SIMD kernels (Highway, dispatched at run time to the
// widest vectors the CPU has: SSE4, AVX2 or AVX-512); the other shapes fall back to the
// scalar LightPointSampler::sample.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace penumbra {

// Per-sample results, one array each (the caller reuses one batch for every point).
struct LightSampleBatch {
  // Arrays are padded to a multiple of this (16 floats: one AVX-512 vector), so kernels can
  // run whole vectors past the last sample; padded lanes hold garbage.
  static constexpr int kLanePad = 16;
  std::vector<float> x, y, z;      // vector from the shading point p to the light point (world)
  std::vector<float> dist;         // its length
  std::vector<float> inv_pdf;      // 1 / (solid-angle density)
  std::vector<float> area_weight;  // AreaLight::DirectionSample::area_weight
  void resize(int n);              // room for n samples (rounded up to kLanePad)
  static size_t padded(int n) { return (static_cast<size_t>(n) + kLanePad - 1) / kLanePad * kLanePad; }
  // What resize(n) allocates (six arrays), for memory estimates.
  static uint64_t bytes(int n) { return 6 * padded(n) * sizeof(float); }
};

namespace light_kernels {

// The spherical rectangle seen from p, in the rectangle's frame (x, y, z) around p: the
// quantities of Urena et al. 2013, Algorithm 1, which LightPointSampler sets up once per point.
struct SphericalRect {
  float x[3], y[3], z[3];  // world axes of the local frame
  float z0, x0, y0, x1, y1, b0, b1, k, solid_angle;
  float inv_area;  // 1 / light area
};

// A cone toward a sphere from p.
struct Cone {
  float s[3], t[3], n[3];  // cone frame, n toward the centre
  float cos_max;
  float to_center[3];       // centre - p
  float dist2_minus_r2;     // |centre - p|^2 - radius^2
  float inv_pdf;            // the cone's solid angle
};

// Warps u = (ux[i], uy[i]), i < n, into `out` (already resized to n). Both arrays must be
// padded to a multiple of LightSampleBatch::kLanePad.
void sample_spherical_rect(const SphericalRect& rect, const float* ux, const float* uy, size_t n,
                           LightSampleBatch& out);
void sample_cone(const Cone& cone, const float* ux, const float* uy, size_t n, LightSampleBatch& out);

// Lambert's formula for a rectangle of unit radiance (corners in order around it) at n points
// p_i = (px[i], py[i], pz[i]) with normals (nx[i], ny[i], nz[i]), the rectangle clipped to
// n's hemisphere: out[i] = 1/2 |sum_k theta_k (n . gamma_k)|, in double precision (far lights
// make the edge terms cancel). Whether the light faces p is the caller's test. Inputs are read
// and outputs written in whole vectors: every array must be padded to a multiple of
// LightSampleBatch::kLanePad.
void rect_irradiance(const double corners[4][3], const float* px, const float* py, const float* pz,
                     const float* nx, const float* ny, const float* nz, size_t n, float* out);

}  // namespace light_kernels
}  // namespace penumbra
