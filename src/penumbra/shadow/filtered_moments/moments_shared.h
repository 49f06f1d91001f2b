// The moment arithmetic of `vsm`, `evsm` and `msm` once for both devices (moments.h and
// models.h state what each function means and which paper it follows), in the common subset of
// C++ and GLSL (core/shader_compat.h, shader_compat_math.h), in double as on the CPU: the
// Chebyshev bound and blocker estimate, the EVSM warps, Hamburger 4MSM's three-point quadrature
// and its blockers, the optimized MSM basis and its 16-bit rounding, and the three models'
// encode, visibility and blockers over one record (FmModel). The CPU's functions and
// MomentModels call these; the GPU kernels (filtered_moments/kernels/) include this header.
// Moment vectors are FilteredChannels (raster/filtered_map_shared.h: four doubles).
#ifndef PENUMBRA_SHADOW_FILTERED_MOMENTS_MOMENTS_SHARED_H
#define PENUMBRA_SHADOW_FILTERED_MOMENTS_MOMENTS_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/core/shader_compat_math.h"
#include "penumbra/raster/filtered_map_shared.h"

PN_SHARED_BEGIN

PN_CONST uint kMomentVsm = 0u;
PN_CONST uint kMomentEvsm = 1u;
PN_CONST uint kMomentMsm = 2u;

// A model and its parameters, 336 bytes (scalar layout; also a GPU buffer's record). Its double
// constants that are no float's value come from the host (fm_model_constants in models.cpp),
// written once for both devices:
//   bytes 0-3 kind (kMoment*)   4-7 channels   8-11 four (evsm: both warps)   12-15 quantize (msm)
//   bytes 16-23 c_pos   24-31 c_neg (evsm exponents)   32-39 min_variance   40-47 alpha (msm bias)
//   bytes 48-55 alpha_limit (0.3)   56-63 alpha_first (1e-6): robust quadrature's biases
//   bytes 64-71 basis_offset (0.035955884801)   72-75 bleeding   76-79 (0)
//   bytes 80-207 basis: the optimized MSM basis M, row-major   208-335 inverse: M's inverse
struct FmModel {
  uint kind;
  int channels;
  uint four;
  uint quantize;
  double c_pos;
  double c_neg;
  double min_variance;
  double alpha;
  double alpha_limit;
  double alpha_first;
  double basis_offset;
  float bleeding;
  uint pad;
  double basis[16];
  double inverse[16];
};

// What a blocker search found: the fraction in front of the receiver, their mean depth.
struct FmBlockers {
  double fraction;
  double depth;
};

// Peters & Klein 2015's three-point quadrature (moments.h MomentQuadrature).
struct FmQuadrature {
  double z[3];
  double w[3];
  double intensity;
};

// moments.h reduce_bleeding.
PN_INLINE float fm_reduce_bleeding(float p, float amount) {
  if (!(amount > 0.0f)) return p;
  float v = (p - amount) / (1.0f - amount);
  return v < 0.0f ? 0.0f : (v > 1.0f ? 1.0f : v);
}

// moments.h chebyshev_upper_bound.
PN_INLINE double fm_chebyshev_upper_bound(double mu, double sigma2, double t) {
  if (t <= mu) return double(1.0f);
  double d = t - mu;
  PN_PRECISE double den = sigma2 + d * d;
  return sigma2 / den;
}

// moments.h chebyshev_blockers (Yang et al. 2010).
PN_INLINE FmBlockers fm_chebyshev_blockers(double mu, double sigma2, double t) {
  FmBlockers b;
  b.fraction = double(0.0f);
  b.depth = double(0.0f);
  double p = fm_chebyshev_upper_bound(mu, sigma2, t);
  if (!(p < double(1.0f))) return b;
  // mu = p t + (1 - p) z_occ; the blockers lie in front of t by definition.
  PN_PRECISE double num = mu - p * t;
  double z = num / (double(1.0f) - p);
  b.fraction = double(1.0f) - p;
  b.depth = pn_dmin(z, t);
  return b;
}

// moments.h evsm_positive_warp / evsm_negative_warp.
PN_INLINE double fm_evsm_positive_warp(double z, double c) { return pn_exp_d(c * (double(2.0f) * z - double(1.0f))); }
PN_INLINE double fm_evsm_negative_warp(double z, double c) { return -pn_exp_d(-c * (double(2.0f) * z - double(1.0f))); }

// The quadrature of the biased moments (moments.cpp quadrature). False when the Hankel matrix
// is singular even after the bias.
PN_INLINE bool fm_quadrature(FilteredChannels moments, double zf, double alpha, PN_OUT(FmQuadrature) q) {
  double b[4];
  for (int i = 0; i < 4; ++i) {
    PN_PRECISE double bi = (double(1.0f) - alpha) * moments.v[i] + alpha * double(0.5f);
    b[i] = bi;
  }
  // H = L D L^T with L = [[1, 0, 0], [b1, 1, 0], [b2, l32, 1]], D = diag(1, d22, d33).
  PN_PRECISE double d22 = b[1] - b[0] * b[0];
  if (!(d22 > double(0.0f))) return false;
  PN_PRECISE double l32 = (b[2] - b[0] * b[1]) / d22;
  PN_PRECISE double d33 = b[3] - b[1] * b[1] - l32 * l32 * d22;
  if (!(d33 > double(0.0f))) return false;
  // Solve H c = (1, zf, zf^2): forward, diagonal, backward.
  double y1 = double(1.0f);
  PN_PRECISE double y2 = zf - b[0] * y1;
  PN_PRECISE double y3 = zf * zf - b[1] * y1 - l32 * y2;
  double c3 = y3 / d33;
  PN_PRECISE double c2 = y2 / d22 - l32 * c3;
  PN_PRECISE double c1 = y1 - b[0] * c2 - b[1] * c3;
  if (!(c3 != double(0.0f))) return false;
  double p = c2 / c3;
  double r = c1 / c3;
  PN_PRECISE double disc = double(0.25f) * p * p - r;
  double root = sqrt(pn_dmax(disc, double(0.0f)));
  PN_PRECISE double z2 = -double(0.5f) * p - root;
  PN_PRECISE double z3 = -double(0.5f) * p + root;
  q.z[0] = zf;
  q.z[1] = z2;
  q.z[2] = z3;
  // Weights from the Vandermonde system of moments 0..2 (Lagrange form).
  double zi[3] = {zf, z2, z3};
  double zj[3] = {z2, zf, zf};
  double zk[3] = {z3, z3, z2};
  bool finite = true;
  for (int i = 0; i < 3; ++i) {
    PN_PRECISE double num = b[1] - b[0] * (zj[i] + zk[i]) + zj[i] * zk[i];
    PN_PRECISE double den = (zi[i] - zj[i]) * (zi[i] - zk[i]);
    q.w[i] = num / den;
    // (A zero denominator is a non-finite weight on the CPU; tested apart for the GPU.)
    finite = finite && den != double(0.0f) && pn_disfinite(q.w[i]);
  }
  return finite;
}

// moments.cpp robust_quadrature: at alpha, or at the smallest of 10 alpha, 100 alpha, ... (up to
// 0.3) that succeeds.
PN_INLINE bool fm_robust_quadrature(FmModel m, FilteredChannels moments, double zf, double alpha,
                                     PN_OUT(FmQuadrature) q) {
  for (double a = alpha; a <= m.alpha_limit; a = a > double(0.0f) ? a * double(10.0f) : m.alpha_first)
    if (fm_quadrature(moments, zf, a, q)) return true;
  return false;
}

// moments.h hamburger_4msm (Peters & Klein 2015, Hamburger 4MSM).
PN_INLINE FmQuadrature fm_hamburger_4msm(FmModel m, FilteredChannels moments, double zf, double alpha) {
  FmQuadrature q;
  for (int i = 0; i < 3; ++i) {
    q.z[i] = double(0.0f);
    q.w[i] = double(0.0f);
  }
  q.intensity = double(0.0f);
  if (!fm_robust_quadrature(m, moments, zf, alpha, q)) {
    // Degenerate moments (a single depth): the region is all in front of zf or not.
    q.intensity = moments.v[0] < zf ? double(1.0f) : double(0.0f);
    return q;
  }
  // The algorithm's three cases: zf <= z2: 0; z2 < zf <= z3: w2; else 1 - w1.
  double intensity;
  if (zf <= q.z[1]) intensity = double(0.0f);
  else if (zf <= q.z[2]) intensity = q.w[1];
  else intensity = double(1.0f) - q.w[0];
  q.intensity = clamp(intensity, double(0.0f), double(1.0f));
  return q;
}

// moments.h moment_blockers (Peters et al. 2016, from the same quadrature).
PN_INLINE FmBlockers fm_moment_blockers(FmModel m, FilteredChannels moments, double zf, double alpha) {
  FmBlockers none;
  none.fraction = double(0.0f);
  none.depth = double(0.0f);
  FmQuadrature q;
  if (!fm_robust_quadrature(m, moments, zf, alpha, q)) {
    if (moments.v[0] < zf) {
      FmBlockers all;
      all.fraction = double(1.0f);
      all.depth = moments.v[0];
      return all;
    }
    return none;
  }
  double weight = double(0.0f);
  double depth = double(0.0f);
  for (int i = 1; i < 3; ++i)
    if (q.z[i] < zf && q.w[i] > double(0.0f)) {
      weight += q.w[i];
      PN_PRECISE double d = depth + q.w[i] * q.z[i];
      depth = d;
    }
  if (!(weight > double(0.0f))) return none;
  FmBlockers b;
  b.fraction = pn_dmin(weight, double(1.0f));
  b.depth = clamp(depth / weight, double(0.0f), zf);
  return b;
}

// The row vector v times the 4 x 4 matrix m (row-major), summed in the CPU's order.
PN_INLINE FilteredChannels fm_row_times(FilteredChannels v, double m[16]) {
  FilteredChannels r;
  for (int j = 0; j < 4; ++j) {
    double s = double(0.0f);
    for (int i = 0; i < 4; ++i) {
      PN_PRECISE double t = s + v.v[i] * m[4 * i + j];
      s = t;
    }
    r.v[j] = s;
  }
  return r;
}

// Peters & Klein 2015, optimized quantization: q = b M + (basis_offset, 0, 0, 0), b the row
// vector of power moments (moments.h msm_optimize).
PN_INLINE FilteredChannels fm_msm_optimize(FmModel m, FilteredChannels b) {
  FilteredChannels q = fm_row_times(b, m.basis);
  q.v[0] += m.basis_offset;
  return q;
}

// The inverse transform (moments.h msm_deoptimize).
PN_INLINE FilteredChannels fm_msm_deoptimize(FmModel m, FilteredChannels q) {
  q.v[0] -= m.basis_offset;
  return fm_row_times(q, m.inverse);
}

// Rounded to the nearest of 65536 levels in [0, 1] (an RGBA16 UNORM texel).
PN_INLINE double fm_quantize_unorm16(double v) {
  PN_PRECISE double scaled = clamp(v, double(0.0f), double(1.0f)) * double(65535.0f) + double(0.5f);
  return pn_dfloor(scaled) / double(65535.0f);
}

// ---------------------------------------------------------------------------------------------
// The models (models.h): what a texel at normalised depth z stores, and what a mean vector says.

// The vector a texel at normalised depth z stores (channels m.channels; the CPU stores them as
// float).
PN_INLINE FilteredChannels fm_encode(FmModel m, double z) {
  FilteredChannels res;
  for (int c = 0; c < 4; ++c) res.v[c] = double(0.0f);
  if (m.kind == kMomentVsm) {
    res.v[0] = z;
    res.v[1] = z * z;
  } else if (m.kind == kMomentEvsm) {
    double p = fm_evsm_positive_warp(z, m.c_pos);
    res.v[0] = p;
    res.v[1] = p * p;
    if (m.four != 0u) {
      double n = fm_evsm_negative_warp(z, m.c_neg);
      res.v[2] = n;
      res.v[3] = n * n;
    }
  } else {
    double z2 = z * z;
    res.v[0] = z;
    res.v[1] = z2;
    res.v[2] = z2 * z;
    res.v[3] = z2 * z2;
    if (m.quantize != 0u) {
      res = fm_msm_optimize(m, res);
      for (int c = 0; c < 4; ++c) res.v[c] = fm_quantize_unorm16(res.v[c]);
    }
  }
  return res;
}

// Chebyshev's bound from the mean of (w, w^2) at warped receiver depth tw (models.cpp bound).
PN_INLINE double fm_bound(double m0, double m1, double tw, double min_variance) {
  PN_PRECISE double variance = m1 - m0 * m0;
  return fm_chebyshev_upper_bound(m0, pn_dmax(variance, min_variance), tw);
}

// Yang et al. 2010's estimate with the receiver's own plane's variance taken out first
// (models.cpp blockers_without_receiver).
PN_INLINE FmBlockers fm_blockers_without_receiver(double m0, double m1, double tw, double receiver_variance,
                                                  double min_variance) {
  PN_PRECISE double raw = m1 - m0 * m0;
  double variance = pn_dmax(raw, min_variance);
  double lit = fm_chebyshev_upper_bound(m0, variance, tw);
  PN_PRECISE double rest = variance - lit * receiver_variance;
  return fm_chebyshev_blockers(m0, pn_dmax(rest, min_variance), tw);
}

// MsmModel::power_moments.
PN_INLINE FilteredChannels fm_power_moments(FmModel m, FilteredChannels mean) {
  return m.quantize != 0u ? fm_msm_deoptimize(m, mean) : mean;
}

// MomentModel::visibility: V at normalised receiver depth t from the mean vector of a filter
// region.
PN_INLINE float fm_model_visibility(FmModel m, FilteredChannels mean, double t) {
  if (m.kind == kMomentVsm) return fm_reduce_bleeding(float(fm_bound(mean.v[0], mean.v[1], t, m.min_variance)), m.bleeding);
  if (m.kind == kMomentEvsm) {
    // The floor in warped units: d(warp)/dz = 2 c warp (x = 2z - 1).
    double tp = fm_evsm_positive_warp(t, m.c_pos);
    double dp = double(2.0f) * m.c_pos * tp;
    double v = fm_bound(mean.v[0], mean.v[1], tp, m.min_variance * dp * dp);
    if (m.four != 0u) {
      double tn = fm_evsm_negative_warp(t, m.c_neg);
      double dn = double(2.0f) * m.c_neg * tn;
      v = pn_dmin(v, fm_bound(mean.v[2], mean.v[3], tn, m.min_variance * dn * dn));
    }
    return fm_reduce_bleeding(float(v), m.bleeding);
  }
  double intensity = fm_hamburger_4msm(m, fm_power_moments(m, mean), t, m.alpha).intensity;
  return fm_reduce_bleeding(float(double(1.0f) - intensity), m.bleeding);
}

// MomentModel::blockers: the blockers the mean vector of a search region shows in front of t,
// the receiver's own tangent plane's variance over the region taken out.
PN_INLINE FmBlockers fm_model_blockers(FmModel m, FilteredChannels mean, double t, double receiver_variance) {
  if (m.kind == kMomentVsm) return fm_blockers_without_receiver(mean.v[0], mean.v[1], t, receiver_variance, m.min_variance);
  if (m.kind == kMomentMsm) return fm_moment_blockers(m, fm_power_moments(m, mean), t, m.alpha);
  // EVSM (models.cpp EvsmModel::blockers): in the negative warp when there is one.
  if (m.four != 0u) {
    double tn = fm_evsm_negative_warp(t, m.c_neg);
    double dn = double(2.0f) * m.c_neg * tn;
    // (Variances scale with the warp's derivative squared.)
    FmBlockers b = fm_blockers_without_receiver(mean.v[2], mean.v[3], tn, receiver_variance * dn * dn,
                                                m.min_variance * dn * dn);
    if (b.fraction > double(0.0f)) {
      // w = -e^(-c x): x = -ln(-w) / c, z = (x + 1) / 2.
      double w = pn_dmin(b.depth, tn);
      b.depth = clamp(double(0.5f) * (double(1.0f) - pn_log_d(-w) / m.c_neg), double(0.0f), t);
    }
    return b;
  }
  double tp = fm_evsm_positive_warp(t, m.c_pos);
  double dp = double(2.0f) * m.c_pos * tp;
  FmBlockers b = fm_blockers_without_receiver(mean.v[0], mean.v[1], tp, receiver_variance * dp * dp,
                                              m.min_variance * dp * dp);
  if (b.fraction > double(0.0f)) {
    // x = ln(w) / c, z = (x + 1) / 2.
    double w = pn_dmax(b.depth, fm_evsm_positive_warp(double(0.0f), m.c_pos));
    b.depth = clamp(double(0.5f) * (pn_log_d(w) / m.c_pos + double(1.0f)), double(0.0f), t);
  }
  return b;
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::FmModel) == 336);
#endif

#endif  // PENUMBRA_SHADOW_FILTERED_MOMENTS_MOMENTS_SHARED_H
