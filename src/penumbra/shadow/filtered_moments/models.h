// The three MomentModels of vsm, evsm and msm (filtered_moments.h), and the parameter
// entries they share. Each is a record of moments_shared.h (FmModel) whose functions both
// devices run; the classes say what the parameters mean.
#pragma once

#include <array>
#include <memory>
#include <string>

#include "penumbra/shadow/filtered_moments/filtered_moments.h"
#include "penumbra/shadow/filtered_moments/moments.h"
#include "penumbra/shadow/filtered_moments/moments_shared.h"
#include "penumbra/shadow/params.h"

namespace penumbra::filtered_moments {

ParamSpec bleeding_param();      // "bleeding": the linstep's lower end (reduce_bleeding)
ParamSpec min_variance_param();  // "min_variance": the variance's floor, normalised depth^2

// A model as its record (moments_shared.h fm_encode, fm_model_visibility, fm_model_blockers).
class SharedMomentModel : public MomentModel {
 public:
  int channels() const override { return m_.channels; }
  void encode(double z, float* out) const override;
  float visibility(const double* mean, double t) const override;
  BlockerEstimate blockers(const double* mean, double t, double receiver_variance) const override;
  shader::FmModel shared() const override { return m_; }

 protected:
  shader::FmModel m_ = fm_model_constants();
};

// Donnelly & Lauritzen 2006: (z, z^2); V = Chebyshev's upper bound, its variance clamped
// below by min_variance (their §3's fix for numerical acne), then the bleeding reduction.
class VsmModel final : public SharedMomentModel {
 public:
  static constexpr int kChannels = 2;
  VsmModel(float min_variance, float bleeding);
};

// Lauritzen & McCool 2008 (EVSM): the VSM of the warped depths exp(c+ x) and, with
// four_components, -exp(-c- x) (x = 2z - 1); V = the smaller of the two bounds. The
// variance floor is min_variance scaled by the warp's derivative at t (the warp stretches
// depth by c e^(c x)), as the warped depths are compared, not the depths. The blockers: Yang
// et al. 2010's estimate in warped depth (the negative warp's when there is one), unwarped.
class EvsmModel final : public SharedMomentModel {
 public:
  EvsmModel(float positive_exponent, float negative_exponent, bool four_components, float min_variance,
            float bleeding);
};

// Peters & Klein 2015: the four power moments (optionally in the optimized basis, rounded to
// 16 bits per channel); V = 1 - the Hamburger 4MSM shadow intensity with moment bias alpha,
// then the bleeding reduction. The blocker search: moment_blockers (Peters et al. 2016).
class MsmModel final : public SharedMomentModel {
 public:
  static constexpr int kChannels = 4;
  MsmModel(float moment_bias, bool quantize, float bleeding);
  // The power moments of a mean vector (undoing the optimized basis when quantize).
  std::array<double, 4> power_moments(const double* mean) const;
};

// The model of method `method` ("vsm", "evsm" or "msm") at parameters `p` (both devices'
// versions make theirs here).
std::unique_ptr<MomentModel> make_moment_model(const std::string& method, const ParamSet& p);
// The channels it stores (for memory estimates).
int moment_channels(const std::string& method, const ParamSet& p);

}  // namespace penumbra::filtered_moments
