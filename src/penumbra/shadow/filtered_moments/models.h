// The three MomentModels of vsm, evsm and msm (filtered_moments.h), and the parameter
// entries they share.
#pragma once

#include <array>

#include "penumbra/shadow/filtered_moments/filtered_moments.h"
#include "penumbra/shadow/filtered_moments/moments.h"
#include "penumbra/shadow/params.h"

namespace penumbra::filtered_moments {

ParamSpec bleeding_param();      // "bleeding": the linstep's lower end (reduce_bleeding)
ParamSpec min_variance_param();  // "min_variance": the variance's floor, normalised depth^2

// Donnelly & Lauritzen 2006: (z, z^2); V = Chebyshev's upper bound, its variance clamped
// below by min_variance (their §3's fix for numerical acne), then the bleeding reduction.
class VsmModel final : public MomentModel {
 public:
  static constexpr int kChannels = 2;
  VsmModel(float min_variance, float bleeding) : min_variance_(min_variance), bleeding_(bleeding) {}
  int channels() const override { return kChannels; }
  void encode(double z, float* out) const override;
  float visibility(const double* mean, double t) const override;
  BlockerEstimate blockers(const double* mean, double t, double receiver_variance) const override;

 private:
  double min_variance_;
  float bleeding_;
};

// Lauritzen & McCool 2008 (EVSM): the VSM of the warped depths exp(c+ x) and, with
// four_components, -exp(-c- x) (x = 2z - 1); V = the smaller of the two bounds. The
// variance floor is min_variance scaled by the warp's derivative at t (the warp stretches
// depth by c e^(c x)), as the warped depths are compared, not the depths.
class EvsmModel final : public MomentModel {
 public:
  EvsmModel(float positive_exponent, float negative_exponent, bool four_components, float min_variance,
            float bleeding)
      : c_pos_(positive_exponent),
        c_neg_(negative_exponent),
        four_(four_components),
        min_variance_(min_variance),
        bleeding_(bleeding) {}
  int channels() const override { return four_ ? 4 : 2; }
  void encode(double z, float* out) const override;
  float visibility(const double* mean, double t) const override;
  // From the positive warp's moments (Yang et al. 2010's estimate in warped depth, unwarped).
  BlockerEstimate blockers(const double* mean, double t, double receiver_variance) const override;

 private:
  double c_pos_, c_neg_;
  bool four_;
  double min_variance_;
  float bleeding_;
};

// Peters & Klein 2015: the four power moments (optionally in the optimized basis, rounded to
// 16 bits per channel); V = 1 - the Hamburger 4MSM shadow intensity with moment bias alpha,
// then the bleeding reduction. The blocker search: moment_blockers (Peters et al. 2016).
class MsmModel final : public MomentModel {
 public:
  static constexpr int kChannels = 4;
  MsmModel(float moment_bias, bool quantize, float bleeding)
      : alpha_(moment_bias), quantize_(quantize), bleeding_(bleeding) {}
  int channels() const override { return kChannels; }
  void encode(double z, float* out) const override;
  float visibility(const double* mean, double t) const override;
  BlockerEstimate blockers(const double* mean, double t, double receiver_variance) const override;
  // The power moments of a mean vector (undoing the optimized basis when quantize).
  std::array<double, 4> power_moments(const double* mean) const;

 private:
  double alpha_;
  bool quantize_;
  float bleeding_;
};

}  // namespace penumbra::filtered_moments
