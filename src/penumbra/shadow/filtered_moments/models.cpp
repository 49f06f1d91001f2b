#include "penumbra/shadow/filtered_moments/models.h"

#include <algorithm>
#include <cmath>

#include "penumbra/core/error.h"

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

shader::FilteredChannels mean_of(const double* m, int channels) {
  shader::FilteredChannels c{};
  for (int i = 0; i < channels; ++i) c.v[i] = m[i];
  return c;
}

}  // namespace

void SharedMomentModel::encode(double z, float* out) const {
  const shader::FilteredChannels e = shader::fm_encode(m_, z);
  for (int c = 0; c < m_.channels; ++c) out[c] = static_cast<float>(e.v[c]);
}

float SharedMomentModel::visibility(const double* m, double t) const {
  return shader::fm_model_visibility(m_, mean_of(m, m_.channels), t);
}

BlockerEstimate SharedMomentModel::blockers(const double* m, double t, double receiver_variance) const {
  const shader::FmBlockers b = shader::fm_model_blockers(m_, mean_of(m, m_.channels), t, receiver_variance);
  return {b.fraction, b.depth};
}

VsmModel::VsmModel(float min_variance, float bleeding) {
  m_.kind = shader::kMomentVsm;
  m_.channels = kChannels;
  m_.min_variance = min_variance;
  m_.bleeding = bleeding;
}

EvsmModel::EvsmModel(float positive_exponent, float negative_exponent, bool four_components, float min_variance,
                     float bleeding) {
  m_.kind = shader::kMomentEvsm;
  m_.channels = four_components ? 4 : 2;
  m_.four = four_components ? 1u : 0u;
  m_.c_pos = positive_exponent;
  m_.c_neg = negative_exponent;
  m_.min_variance = min_variance;
  m_.bleeding = bleeding;
}

MsmModel::MsmModel(float moment_bias, bool quantize, float bleeding) {
  m_.kind = shader::kMomentMsm;
  m_.channels = kChannels;
  m_.quantize = quantize ? 1u : 0u;
  m_.alpha = moment_bias;
  m_.bleeding = bleeding;
}

std::array<double, 4> MsmModel::power_moments(const double* m) const {
  const shader::FilteredChannels p = shader::fm_power_moments(m_, mean_of(m, kChannels));
  return {p.v[0], p.v[1], p.v[2], p.v[3]};
}

std::unique_ptr<MomentModel> make_moment_model(const std::string& method, const ParamSet& p) {
  if (method == "vsm") return std::make_unique<VsmModel>(p.get_float("min_variance"), p.get_float("bleeding"));
  if (method == "evsm") {
    const int components = p.get_int("components");
    if (components != 2 && components != 4) throw Error("evsm.components: {} is not one of 2, 4", components);
    return std::make_unique<EvsmModel>(p.get_float("positive_exponent"), p.get_float("negative_exponent"),
                                       components == 4, p.get_float("min_variance"), p.get_float("bleeding"));
  }
  if (method == "msm")
    return std::make_unique<MsmModel>(p.get_float("moment_bias"), p.get_bool("quantize"), p.get_float("bleeding"));
  throw Error("{} is not a filtered-moment method", method);
}

int moment_channels(const std::string& method, const ParamSet& p) {
  if (method == "evsm") return p.get_int("components");
  return method == "vsm" ? VsmModel::kChannels : MsmModel::kChannels;
}

}  // namespace penumbra::filtered_moments
