// The moment arithmetic is moments_shared.h's (both devices run it); these are its C++ faces,
// and the host's half of it: the double constants the shared code reads from its record.
#include "penumbra/shadow/filtered_moments/moments.h"

#include <algorithm>
#include <cmath>

namespace penumbra::filtered_moments {
namespace {

// Peters & Klein 2015, optimized quantization: q = b M + (0.035955884801, 0, 0, 0), b the
// row vector of power moments.
constexpr double kOptimize[4][4] = {
    {-2.07224649, 13.7948857237, 0.105877704, 9.7924062118},
    {32.23703778, -59.4683975703, -1.9077466311, -33.7652110555},
    {-68.571074599, 82.0359750338, 9.3496555107, 47.9456096605},
    {39.3703274134, -35.364903257, -6.6543490743, -23.9728048165},
};
constexpr double kOptimizeOffset = 0.035955884801;

// The inverse of kOptimize, by Gauss-Jordan elimination with partial pivoting (computed
// once, rather than a second table of transcribed digits).
struct Inverse {
  double m[4][4];
  Inverse() {
    double a[4][8];
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 8; ++j) a[i][j] = j < 4 ? kOptimize[i][j] : (j - 4 == i ? 1.0 : 0.0);
    for (int col = 0; col < 4; ++col) {
      int pivot = col;
      for (int r = col + 1; r < 4; ++r)
        if (std::abs(a[r][col]) > std::abs(a[pivot][col])) pivot = r;
      for (int j = 0; j < 8; ++j) std::swap(a[col][j], a[pivot][j]);
      const double inv = 1.0 / a[col][col];
      for (int j = 0; j < 8; ++j) a[col][j] *= inv;
      for (int r = 0; r < 4; ++r)
        if (r != col) {
          const double f = a[r][col];
          for (int j = 0; j < 8; ++j) a[r][j] -= f * a[col][j];
        }
    }
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) m[i][j] = a[i][j + 4];
  }
};

shader::FilteredChannels as_channels(const std::array<double, 4>& b) { return {{b[0], b[1], b[2], b[3]}}; }
std::array<double, 4> as_array(const shader::FilteredChannels& c) { return {c.v[0], c.v[1], c.v[2], c.v[3]}; }
BlockerEstimate as_estimate(const shader::FmBlockers& b) { return {b.fraction, b.depth}; }

}  // namespace

shader::FmModel fm_model_constants() {
  static const Inverse inv;
  shader::FmModel m{};
  // robust_quadrature's biases: 10 alpha, 100 alpha, ... up to 0.3; from 1e-6 when alpha = 0.
  m.alpha_limit = 0.3;
  m.alpha_first = 1e-6;
  m.basis_offset = kOptimizeOffset;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      m.basis[4 * i + j] = kOptimize[i][j];
      m.inverse[4 * i + j] = inv.m[i][j];
    }
  return m;
}

namespace {
const shader::FmModel& model_constants() {
  static const shader::FmModel m = fm_model_constants();
  return m;
}
}  // namespace

BlockerEstimate chebyshev_blockers(double mu, double sigma2, double t) {
  return as_estimate(shader::fm_chebyshev_blockers(mu, sigma2, t));
}

MomentQuadrature hamburger_4msm(const std::array<double, 4>& moments, double zf, double alpha) {
  const shader::FmQuadrature q = shader::fm_hamburger_4msm(model_constants(), as_channels(moments), zf, alpha);
  MomentQuadrature out;
  std::copy(q.z, q.z + 3, out.z);
  std::copy(q.w, q.w + 3, out.w);
  out.intensity = q.intensity;
  return out;
}

BlockerEstimate moment_blockers(const std::array<double, 4>& moments, double zf, double alpha) {
  return as_estimate(shader::fm_moment_blockers(model_constants(), as_channels(moments), zf, alpha));
}

std::array<double, 4> msm_optimize(const std::array<double, 4>& b) {
  return as_array(shader::fm_msm_optimize(model_constants(), as_channels(b)));
}

std::array<double, 4> msm_deoptimize(const std::array<double, 4>& q) {
  return as_array(shader::fm_msm_deoptimize(model_constants(), as_channels(q)));
}

double quantize_unorm16(double v) { return shader::fm_quantize_unorm16(v); }

}  // namespace penumbra::filtered_moments
