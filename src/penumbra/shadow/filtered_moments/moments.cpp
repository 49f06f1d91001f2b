#include "penumbra/shadow/filtered_moments/moments.h"

#include <algorithm>
#include <cmath>

namespace penumbra::filtered_moments {

BlockerEstimate chebyshev_blockers(double mu, double sigma2, double t) {
  const double p = chebyshev_upper_bound(mu, sigma2, t);
  if (!(p < 1)) return {};
  // mu = p t + (1 - p) z_occ; the blockers lie in front of t by definition.
  const double z = (mu - p * t) / (1 - p);
  return {1 - p, std::min(z, t)};
}

namespace {

// The three-point quadrature of the biased moments (see the header). False when the Hankel
// matrix is singular even after the bias (alpha = 0 on a distribution of < 3 points).
bool quadrature(const std::array<double, 4>& moments, double zf, double alpha, MomentQuadrature& q) {
  double b[4];
  for (int i = 0; i < 4; ++i) b[i] = (1 - alpha) * moments[i] + alpha * 0.5;
  // H = L D L^T with L = [[1, 0, 0], [b1, 1, 0], [b2, l32, 1]], D = diag(1, d22, d33).
  const double d22 = b[1] - b[0] * b[0];
  if (!(d22 > 0)) return false;
  const double l32 = (b[2] - b[0] * b[1]) / d22;
  const double d33 = b[3] - b[1] * b[1] - l32 * l32 * d22;
  if (!(d33 > 0)) return false;
  // Solve H c = (1, zf, zf^2): forward, diagonal, backward.
  const double y1 = 1, y2 = zf - b[0] * y1, y3 = zf * zf - b[1] * y1 - l32 * y2;
  const double c3 = y3 / d33, c2 = y2 / d22 - l32 * c3, c1 = y1 - b[0] * c2 - b[1] * c3;
  // Roots of c3 z^2 + c2 z + c1 (c3 > 0: zf's kernel polynomial is positive away from the
  // other nodes).
  if (!(c3 != 0)) return false;
  const double p = c2 / c3, r = c1 / c3;
  const double root = std::sqrt(std::max(0.25 * p * p - r, 0.0));
  const double z2 = -0.5 * p - root, z3 = -0.5 * p + root;
  q.z[0] = zf;
  q.z[1] = z2;
  q.z[2] = z3;
  // Weights from the Vandermonde system of moments 0..2 (Lagrange form).
  auto weight = [&](double zi, double zj, double zk) { return (b[1] - b[0] * (zj + zk) + zj * zk) / ((zi - zj) * (zi - zk)); };
  q.w[0] = weight(zf, z2, z3);
  q.w[1] = weight(z2, zf, z3);
  q.w[2] = weight(z3, zf, z2);
  return std::isfinite(q.w[0]) && std::isfinite(q.w[1]) && std::isfinite(q.w[2]);
}

// The quadrature at alpha, or, where rounding has moved the moments outside the moment
// space by more than alpha pulls them back (16-bit storage of a region of one or two depths:
// 7 of 181 single depths and 13 of 57 two-depth mixes fail at 3e-5, docs/methods/msm.md), at
// the smallest of 10 alpha, 100 alpha, ... (up to 0.3) that succeeds.
bool robust_quadrature(const std::array<double, 4>& moments, double zf, double alpha, MomentQuadrature& q) {
  for (double a = alpha; a <= 0.3; a = a > 0 ? a * 10 : 1e-6)
    if (quadrature(moments, zf, a, q)) return true;
  return false;
}

}  // namespace

MomentQuadrature hamburger_4msm(const std::array<double, 4>& moments, double zf, double alpha) {
  MomentQuadrature q;
  if (!robust_quadrature(moments, zf, alpha, q)) {
    // Degenerate moments (a single depth): the region is all in front of zf or not.
    q.intensity = moments[0] < zf ? 1.0 : 0.0;
    return q;
  }
  // The algorithm's three cases: zf <= z2: 0; z2 < zf <= z3: w2; else 1 - w1.
  double intensity;
  if (zf <= q.z[1]) intensity = 0;
  else if (zf <= q.z[2]) intensity = q.w[1];
  else intensity = 1 - q.w[0];
  q.intensity = std::clamp(intensity, 0.0, 1.0);
  return q;
}

BlockerEstimate moment_blockers(const std::array<double, 4>& moments, double zf, double alpha) {
  MomentQuadrature q;
  if (!robust_quadrature(moments, zf, alpha, q)) {
    if (moments[0] < zf) return {1.0, moments[0]};
    return {};
  }
  double weight = 0, depth = 0;
  for (int i = 1; i < 3; ++i)
    if (q.z[i] < zf && q.w[i] > 0) {
      weight += q.w[i];
      depth += q.w[i] * q.z[i];
    }
  if (!(weight > 0)) return {};
  return {std::min(weight, 1.0), std::clamp(depth / weight, 0.0, zf)};
}

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

const Inverse& inverse() {
  static const Inverse inv;
  return inv;
}

}  // namespace

std::array<double, 4> msm_optimize(const std::array<double, 4>& b) {
  std::array<double, 4> q{};
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) q[j] += b[i] * kOptimize[i][j];
  q[0] += kOptimizeOffset;
  return q;
}

std::array<double, 4> msm_deoptimize(const std::array<double, 4>& q) {
  const Inverse& inv = inverse();
  std::array<double, 4> in = q, b{};
  in[0] -= kOptimizeOffset;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) b[j] += in[i] * inv.m[i][j];
  return b;
}

double quantize_unorm16(double v) { return std::round(std::clamp(v, 0.0, 1.0) * 65535.0) / 65535.0; }

}  // namespace penumbra::filtered_moments
