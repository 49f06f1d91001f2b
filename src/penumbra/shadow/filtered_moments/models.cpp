#include "penumbra/shadow/filtered_moments/models.h"

#include <algorithm>
#include <cmath>

namespace penumbra::filtered_moments {

ParamSpec bleeding_param() {
  return {"bleeding", ParamType::Float, 0.0,
          "light-bleeding reduction: visibilities below this are cut to 0 and [bleeding, 1] stretched to [0, 1] "
          "(Lauritzen, GPU Gems 3 ch. 8); 0: off. Darkens penumbrae as it removes bleeding",
          {}, 0, 0.99};
}

ParamSpec min_variance_param() {
  return {"min_variance", ParamType::Float, 1e-6,
          "lower bound on the filtered variance, in normalised depth^2 (Donnelly & Lauritzen 2006: against "
          "numerical acne on lit surfaces)",
          {}, 0, 1};
}

namespace {

// Chebyshev's bound from the mean of (w, w^2) at warped receiver depth tw.
double bound(const double* m, double tw, double min_variance) {
  const double variance = std::max(m[1] - m[0] * m[0], min_variance);
  return chebyshev_upper_bound(m[0], variance, tw);
}

// Yang et al. 2010's blocker estimate from the mean of (w, w^2), the receiver's own plane's
// variance over the region taken out first (it is spread around t, not in front of it, and
// would push the two-point fit's blocker depth toward the light: the filter grows and the
// umbra lightens), weighted by the part of the region that is not blocker.
BlockerEstimate blockers_without_receiver(const double* m, double tw, double receiver_variance, double min_variance) {
  const double variance = std::max(m[1] - m[0] * m[0], min_variance);
  const double lit = chebyshev_upper_bound(m[0], variance, tw);
  return chebyshev_blockers(m[0], std::max(variance - lit * receiver_variance, min_variance), tw);
}

}  // namespace

// ---------------------------------------------------------------------------------------
// VSM

void VsmModel::encode(double z, float* out) const {
  out[0] = static_cast<float>(z);
  out[1] = static_cast<float>(z * z);
}

float VsmModel::visibility(const double* m, double t) const {
  return reduce_bleeding(static_cast<float>(bound(m, t, min_variance_)), bleeding_);
}

BlockerEstimate VsmModel::blockers(const double* m, double t, double receiver_variance) const {
  return blockers_without_receiver(m, t, receiver_variance, min_variance_);
}

// ---------------------------------------------------------------------------------------
// EVSM

void EvsmModel::encode(double z, float* out) const {
  const double p = evsm_positive_warp(z, c_pos_);
  out[0] = static_cast<float>(p);
  out[1] = static_cast<float>(p * p);
  if (four_) {
    const double n = evsm_negative_warp(z, c_neg_);
    out[2] = static_cast<float>(n);
    out[3] = static_cast<float>(n * n);
  }
}

float EvsmModel::visibility(const double* m, double t) const {
  // The floor in warped units: d(warp)/dz = 2 c warp (x = 2z - 1).
  const double tp = evsm_positive_warp(t, c_pos_), dp = 2 * c_pos_ * tp;
  double v = bound(m, tp, min_variance_ * dp * dp);
  if (four_) {
    const double tn = evsm_negative_warp(t, c_neg_), dn = 2 * c_neg_ * tn;
    v = std::min(v, bound(m + 2, tn, min_variance_ * dn * dn));
  }
  return reduce_bleeding(static_cast<float>(v), bleeding_);
}

BlockerEstimate EvsmModel::blockers(const double* m, double t, double receiver_variance) const {
  // Yang et al. 2010's estimate in warped depth, unwarped. With the negative warp when there
  // is one: -e^(-c x) is largest in magnitude for the nearest depths, so the receiver's own
  // warped depth (which the estimate subtracts, weighted by the Chebyshev bound) is small
  // next to the blockers'. In the positive warp it is the largest value of all, and an
  // upper bound p on the lit fraction times it swamps the blockers' mean.
  if (four_) {
    const double tn = evsm_negative_warp(t, c_neg_), dn = 2 * c_neg_ * tn;
    // (Variances scale with the warp's derivative squared.)
    BlockerEstimate b = blockers_without_receiver(m + 2, tn, receiver_variance * dn * dn, min_variance_ * dn * dn);
    if (b.fraction > 0) {
      // w = -e^(-c x): x = -ln(-w) / c, z = (x + 1) / 2.
      const double w = std::min(b.depth, tn);
      b.depth = std::clamp(0.5 * (1 - std::log(-w) / c_neg_), 0.0, t);
    }
    return b;
  }
  const double tp = evsm_positive_warp(t, c_pos_), dp = 2 * c_pos_ * tp;
  BlockerEstimate b = blockers_without_receiver(m, tp, receiver_variance * dp * dp, min_variance_ * dp * dp);
  if (b.fraction > 0) {
    // x = ln(w) / c, z = (x + 1) / 2.
    const double w = std::max(b.depth, evsm_positive_warp(0.0, c_pos_));
    b.depth = std::clamp(0.5 * (std::log(w) / c_pos_ + 1), 0.0, t);
  }
  return b;
}

// ---------------------------------------------------------------------------------------
// MSM

void MsmModel::encode(double z, float* out) const {
  const double z2 = z * z;
  std::array<double, 4> b = {z, z2, z2 * z, z2 * z2};
  if (quantize_) {
    b = msm_optimize(b);
    for (double& v : b) v = quantize_unorm16(v);
  }
  for (int i = 0; i < 4; ++i) out[i] = static_cast<float>(b[i]);
}

std::array<double, 4> MsmModel::power_moments(const double* m) const {
  std::array<double, 4> b = {m[0], m[1], m[2], m[3]};
  return quantize_ ? msm_deoptimize(b) : b;
}

float MsmModel::visibility(const double* m, double t) const {
  const double intensity = hamburger_4msm(power_moments(m), t, alpha_).intensity;
  return reduce_bleeding(static_cast<float>(1 - intensity), bleeding_);
}

BlockerEstimate MsmModel::blockers(const double* m, double t, double /*receiver_variance*/) const {
  return moment_blockers(power_moments(m), t, alpha_);
}

}  // namespace penumbra::filtered_moments
