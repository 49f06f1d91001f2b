// `rt-denoised`'s per-pixel arithmetic once for both devices (atrous_filter.h states the method:
// SVGF's spatial filter, Schied et al. 2017 §4.1-4.3, over Heitz et al. 2018's ratio estimator),
// in the common subset of C++ and GLSL (core/shader_compat.h, shader_compat_math.h): one fan's
// sums, V of a pixel, the depth gradient, the edge-stopping weights, the spatial variance
// estimate, the variance's 3 x 3 prefilter and one a-trous tap set. atrous_filter.cpp and
// denoised.cpp call these; the GPU kernels (denoised/kernels/) include this header. Sums are in
// double where the CPU's are; exp and pow within an ulp on both devices (shader_compat_math.h).
//
// An image is a set of planes read through DenoiseImage: pixel (x, y) of a width x height image
// is element (y width + x) pixel_stride + pixel_offset of each plane (the CPU's GuidedImage:
// stride 1, offset 0; on the GPU the view-sample slots: stride = samples per pixel, offset = the
// camera ray's index within its pixel, one image per index as on the CPU).
#ifndef PENUMBRA_SHADOW_DENOISED_ATROUS_SHARED_H
#define PENUMBRA_SHADOW_DENOISED_ATROUS_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/core/shader_compat_math.h"

PN_SHARED_BEGIN

// atrous_filter.h AtrousSettings (iterations apart).
struct DenoiseSettings {
  float sigma_z;
  float sigma_n;
  float sigma_l;
};

// Keeps the weights finite where the depth does not change (a plane facing the camera) and
// where the variance is 0 (a fully lit or fully shadowed neighbourhood): §4.3's epsilon. The
// depth's is relative to the depth (plus an absolute floor): a hit point's float position is
// exact to a few ulps of its depth, and an epsilon below that (1e-6 world units was about two
// ulps at depth 5) made the depth weight of a fronto-parallel surface decide on rounding, so
// that two ray tracers' hit points (Embree's, the GPU's) gave different pictures.
PN_CONST float kDenoiseEpsilonDepth = 1e-6f;
PN_CONST float kDenoiseRelativeEpsilonDepth = 1e-4f;
PN_CONST float kDenoiseEpsilonLuminance = 1e-4f;

// The planes of one image (GuidedImage's), and where its pixels are in them.
struct DenoiseImage {
  int width;
  int height;
  uint pixel_stride;
  uint pixel_offset;
  PN_BYTE_ARRAY valid;        // 1: a surface (0: the background, or no camera ray of this layer)
  PN_FLOAT_ARRAY depth;       // linear view depth
  PN_VEC3_ARRAY normal;       // unit shading normal
  PN_FLOAT_ARRAY shadowed;    // S = sum_i T_i f_i / N
  PN_FLOAT_ARRAY unshadowed;  // U = sum_i f_i / N
  PN_FLOAT_ARRAY area;        // A = sum_i T_i a_i / sum_i a_i: the fraction of the light's area seen
  PN_FLOAT_ARRAY variance;    // Var(S / U)
};

PN_INLINE uint dn_index(DenoiseImage img, int x, int y) {
  return (uint(y) * uint(img.width) + uint(x)) * img.pixel_stride + img.pixel_offset;
}
PN_INLINE bool dn_inside(DenoiseImage img, int x, int y) { return x >= 0 && y >= 0 && x < img.width && y < img.height; }
PN_INLINE bool dn_valid(DenoiseImage img, uint i) { return PN_AT(img.valid, i) != uint8_t(0); }

// The smallest normal float. GPUs flush subnormal floats to 0 (Vulkan allows it; lavapipe does),
// and so does a CPU thread whose MXCSR has flush-to-zero and denormals-are-zero set (most likely
// what Embree leaves on the threads it has run: without this, a CPU render's picture changed after
// Embree's BVH builder had run in the same process, by 5e-4 mean |dV| on the foliage). Values below
// it count as 0 wherever a decision or a division hangs on them.
PN_CONST float kDenoiseSmallestNormal = 1.17549435e-38f;
PN_INLINE float dn_flush_subnormal(float x) { return abs(x) < kDenoiseSmallestNormal ? 0.0f : x; }

// GuidedImage::ratio: the irradiance ratio R = S / U (what multiplies the closed-form unshadowed
// irradiance), or the area fraction where U is 0 (or subnormal), clamped to [0, 1]. Also the
// filter's guide (eq. 5's luminance).
PN_INLINE float dn_ratio(DenoiseImage img, uint i) {
  float u = dn_flush_subnormal(PN_AT(img.unshadowed, i));
  float v = u > 0.0f ? dn_flush_subnormal(PN_AT(img.shadowed, i)) / u : PN_AT(img.area, i);
  return clamp(v, 0.0f, 1.0f);
}

// GuidedImage::visibility: V, the fraction of the light's area seen (`reference`'s V: samples
// behind a closed receiver's tangent plane count as blocked), clamped to [0, 1].
PN_INLINE float dn_visibility(DenoiseImage img, uint i) { return clamp(PN_AT(img.area, i), 0.0f, 1.0f); }

// The depth guide of a view sample at p: its linear depth along the camera's axis.
PN_INLINE float dn_view_depth(vec3 p, vec3 eye, vec3 forward) { return dot(p - eye, forward); }

// One fan's sums (denoised.cpp): the shadowed and unshadowed estimates of the same samples
// (Heitz et al. 2018 §3), the area-weighted visibility, and the spread of the ratio estimate.
struct DenoiseFanSums {
  double sf;   // sum T f
  double f;    // sum f
  double sa;   // sum T a
  double a;    // sum a
  double sf2;  // sum f^2 (T - R)^2, R = sf / f
};
PN_INLINE DenoiseFanSums dn_fan_begin() {
  DenoiseFanSums s;
  s.sf = double(0.0f);
  s.f = double(0.0f);
  s.sa = double(0.0f);
  s.a = double(0.0f);
  s.sf2 = double(0.0f);
  return s;
}
// A sample of transmittance t, irradiance term f and area weight a.
PN_INLINE void dn_fan_add(PN_INOUT(DenoiseFanSums) s, float t, float f, float a) {
  double dt = double(t);
  PN_PRECISE double sf = s.sf + dt * double(f);
  PN_PRECISE double sa = s.sa + dt * double(a);
  s.sf = sf;
  s.f += double(f);
  s.sa = sa;
  s.a += double(a);
}
// The same sample again, once every sample is in: its share of the ratio estimate's variance
// (the delta method, as for self-normalised estimators).
PN_INLINE void dn_fan_add_spread(PN_INOUT(DenoiseFanSums) s, float t, float f) {
  double r = s.f > double(0.0f) ? s.sf / s.f : double(0.0f);
  double d = double(t) - r;
  PN_PRECISE double sf2 = s.sf2 + double(f) * double(f) * d * d;
  s.sf2 = sf2;
}

// What a fan of `samples` light samples gives a pixel.
struct DenoisePixel {
  float shadowed;
  float unshadowed;
  float area;
  float variance;
};
PN_INLINE DenoisePixel dn_fan_pixel(DenoiseFanSums s, int samples) {
  DenoisePixel p;
  p.shadowed = float(s.sf / double(samples));
  p.unshadowed = float(s.f / double(samples));
  p.area = s.a > double(0.0f) ? float(s.sa / s.a) : 0.0f;
  p.variance = s.f > double(0.0f) ? float(s.sf2 / (s.f * s.f)) : 0.0f;
  return p;
}

// The screen-space depth gradient (dz/dx, dz/dy) of a valid pixel, each from the one-sided
// difference of smaller magnitude: SVGF takes the hardware derivative of clip-space depth inside
// a triangle; the smaller one-sided difference is that derivative wherever one side lies on the
// same surface, and never the jump across a depth discontinuity.
PN_INLINE float dn_one_sided(DenoiseImage img, int x, int y, int dx, int dy) {
  float p = PN_AT(img.depth, dn_index(img, x, y));
  float best = 0.0f;
  bool found = false;
  for (int k = 0; k < 2; ++k) {
    int sgn = k == 0 ? -1 : 1;
    int qx = x + sgn * dx;
    int qy = y + sgn * dy;
    if (!dn_inside(img, qx, qy)) continue;
    uint j = dn_index(img, qx, qy);
    if (!dn_valid(img, j)) continue;
    float d = (PN_AT(img.depth, j) - p) * float(sgn);
    if (!found || abs(d) < abs(best)) best = d;
    found = true;
  }
  return best;
}
PN_INLINE vec2 dn_depth_gradient(DenoiseImage img, int x, int y) {
  return vec2(dn_one_sided(img, x, y, 1, 0), dn_one_sided(img, x, y, 0, 1));
}

// A weight below the smallest normal float counts as 0 (kDenoiseSmallestNormal): a pixel whose
// every neighbour's weight is that small would otherwise take its V from a subnormal weight on one
// device and its fallback on the other. (Products of weights and signals are summed in double,
// where nothing is subnormal.)
PN_INLINE float dn_normal_weight(float w) { return dn_flush_subnormal(w); }

// §4.3 eq. 3 and 4: the depth and normal weights of q seen from p (gradient grad_p) at pixel
// offset (dx, dy).
PN_INLINE float dn_geometry_weight(DenoiseImage img, vec2 grad_p, uint p, uint q, float dx, float dy, DenoiseSettings s) {
  PN_PRECISE float expected = abs(grad_p.x * dx + grad_p.y * dy);
  float zp = PN_AT(img.depth, p);
  PN_PRECISE float scale = s.sigma_z * expected + kDenoiseRelativeEpsilonDepth * abs(zp) + kDenoiseEpsilonDepth;
  float w_z = pn_expf(-abs(zp - PN_AT(img.depth, q)) / scale);
  vec3 np = PN_AT(img.normal, p);
  vec3 nq = PN_AT(img.normal, q);
  PN_PRECISE float c = np.x * nq.x + np.y * nq.y + np.z * nq.z;
  float w_n = pn_powf(max(0.0f, c), s.sigma_n);
  return w_z * w_n;
}

// §4.1's fallback for short histories: the variance of V over a 7 x 7 neighbourhood, bilaterally
// weighted by depth and normal (w_z w_n). `grad`: every pixel's depth gradient, in the image's
// layout.
PN_INLINE float dn_spatial_variance(DenoiseImage img, PN_VEC2_ARRAY grad, int x, int y, DenoiseSettings s) {
  uint p = dn_index(img, x, y);
  vec2 gp = PN_AT(grad, p);
  double wsum = double(0.0f);
  double m1 = double(0.0f);
  double m2 = double(0.0f);
  for (int dy = -3; dy <= 3; ++dy)
    for (int dx = -3; dx <= 3; ++dx) {
      int qx = x + dx;
      int qy = y + dy;
      if (!dn_inside(img, qx, qy)) continue;
      uint q = dn_index(img, qx, qy);
      if (!dn_valid(img, q)) continue;
      float w = dn_normal_weight(dn_geometry_weight(img, gp, p, q, float(dx), float(dy), s));
      double v = double(dn_ratio(img, q));
      wsum += double(w);
      m1 += double(w) * v;
      PN_PRECISE double m2_next = m2 + double(w) * v * v;
      m2 = m2_next;
    }
  if (!(wsum > double(0.0f))) return 0.0f;
  double mean = m1 / wsum;
  PN_PRECISE double var = m2 / wsum - mean * mean;
  return float(pn_dmax(double(0.0f), var));
}

// §4.3 eq. 5: the variance prefiltered by a 3 x 3 Gaussian (it is itself noisy), over the valid
// pixels.
PN_INLINE float dn_prefiltered_variance(DenoiseImage img, int x, int y) {
  float g3[3] = {0.25f, 0.5f, 0.25f};
  float sum = 0.0f;
  float wsum = 0.0f;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      int qx = x + dx;
      int qy = y + dy;
      if (!dn_inside(img, qx, qy)) continue;
      uint q = dn_index(img, qx, qy);
      if (!dn_valid(img, q)) continue;
      float w = g3[dx + 1] * g3[dy + 1];
      PN_PRECISE float t = sum + w * PN_AT(img.variance, q);
      sum = t;
      wsum += w;
    }
  return sum / wsum;
}

// One a-trous pass at a valid pixel (§4.2): the 5 x 5 B3-spline kernel with taps `step` pixels
// apart, each weighted by depth, normal and V (eq. 5, scaled by the prefiltered standard deviation
// `prefiltered_var` of p); S, U and the area fraction A with the same weights, the variance with
// their squares.
struct DenoiseFiltered {
  float shadowed;
  float unshadowed;
  float area;
  float variance;
};
PN_INLINE DenoiseFiltered dn_atrous(DenoiseImage img, PN_VEC2_ARRAY grad, float prefiltered_var, int x, int y, int step,
                                    DenoiseSettings s) {
  float b3[5] = {0.0625f, 0.25f, 0.375f, 0.25f, 0.0625f};
  uint p = dn_index(img, x, y);
  vec2 gp = PN_AT(grad, p);
  float v_p = dn_ratio(img, p);
  PN_PRECISE float l_scale = s.sigma_l * sqrt(prefiltered_var) + kDenoiseEpsilonLuminance;
  double ws = double(0.0f);
  double wu = double(0.0f);
  double wa = double(0.0f);
  double wvar = double(0.0f);
  double wsum = double(0.0f);
  for (int ky = -2; ky <= 2; ++ky)
    for (int kx = -2; kx <= 2; ++kx) {
      int qx = x + kx * step;
      int qy = y + ky * step;
      if (!dn_inside(img, qx, qy)) continue;
      uint q = dn_index(img, qx, qy);
      if (!dn_valid(img, q)) continue;
      float w_l = pn_expf(-abs(v_p - dn_ratio(img, q)) / l_scale);
      float w = dn_normal_weight(b3[kx + 2] * b3[ky + 2] *
                                 dn_geometry_weight(img, gp, p, q, float(kx * step), float(ky * step), s) * w_l);
      PN_PRECISE double ws_next = ws + double(w) * double(PN_AT(img.shadowed, q));
      PN_PRECISE double wu_next = wu + double(w) * double(PN_AT(img.unshadowed, q));
      PN_PRECISE double wa_next = wa + double(w) * double(PN_AT(img.area, q));
      ws = ws_next;
      wu = wu_next;
      wa = wa_next;
      PN_PRECISE double wv = wvar + double(w) * double(w) * double(PN_AT(img.variance, q));  // §4.2: w^2
      wvar = wv;
      wsum += double(w);
    }
  // The centre tap has weight b3[2]^2 > 0 (w_z = w_n = w_l = 1): wsum > 0.
  DenoiseFiltered r;
  r.shadowed = float(ws / wsum);
  r.unshadowed = float(wu / wsum);
  r.area = float(wa / wsum);
  r.variance = float(wvar / (wsum * wsum));
  return r;
}

PN_SHARED_END

#endif  // PENUMBRA_SHADOW_DENOISED_ATROUS_SHARED_H
