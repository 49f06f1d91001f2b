// The moment arithmetic of the filtered-moment shadow maps (docs/methods/vsm.md, msm.md), the
// C++ faces of moments_shared.h (which the GPU kernels run too):
// what a texel stores for a depth, and what a filtered (mean) vector of those says about a
// receiver at depth t. Depths are normalised to [0, 1] (0: the nearest caster, 1: the
// farthest surface of the map; an empty texel stores the moments of depth 1). Pure
// functions, tested against closed forms in filtered_moments_test.cpp.
#pragma once

#include <array>
#include <cmath>

#include "penumbra/shadow/filtered_moments/moments_shared.h"

namespace penumbra::filtered_moments {

// Lauritzen, GPU Gems 3 ch. 8 (light bleeding): remap [amount, 1] to [0, 1], so that
// upper bounds below `amount` (the bleeding) become 0. amount = 0 leaves p unchanged.
inline float reduce_bleeding(float p, float amount) { return shader::fm_reduce_bleeding(p, amount); }

// Donnelly & Lauritzen 2006 (the one-tailed Chebyshev inequality): the upper bound on the
// fraction of the filter region at depth >= t, from the mean mu and variance sigma2 of its
// depths: 1 if t <= mu, else sigma2 / (sigma2 + (t - mu)^2).
inline double chebyshev_upper_bound(double mu, double sigma2, double t) {
  return shader::fm_chebyshev_upper_bound(mu, sigma2, t);
}

// What a blocker search finds in its region: the fraction in front of the receiver and the
// mean (normalised) depth of that part.
struct BlockerEstimate {
  double fraction = 0;
  double depth = 0;
};

// Variance soft shadow maps (Yang, Dong, Feng, Seidel, Kautz 2010): over the search
// region with moments (mu, sigma2), the fraction p = chebyshev_upper_bound at depth >= t
// lies (by assumption) at t, the rest at the blockers' mean depth z_occ:
// mu = p t + (1 - p) z_occ (at most t). Exact for one planar occluder over a planar
// receiver.
BlockerEstimate chebyshev_blockers(double mu, double sigma2, double t);

// Lauritzen & McCool 2008 (exponential warp of layered VSMs, "EVSM"): depth z in [0, 1]
// mapped to x = 2 z - 1 in [-1, 1], warped to exp(c x) (positive) and -exp(-c x)
// (negative).
inline double evsm_positive_warp(double z, double c) { return shader::fm_evsm_positive_warp(z, c); }
inline double evsm_negative_warp(double z, double c) { return shader::fm_evsm_negative_warp(z, c); }

// Peters & Klein 2015 ("Moment shadow mapping", the algorithm "Hamburger 4MSM"): the
// biased moments b' = (1 - alpha) b + alpha (0.5, 0.5, 0.5, 0.5), then the three-point
// quadrature of b' with one node at the fragment depth zf (the canonical representation;
// the other nodes z2 <= z3 are the roots of the quadratic whose coefficients solve the
// Hankel system H c = (1, zf, zf^2), H = [[1, b1, b2], [b1, b2, b3], [b2, b3, b4]],
// Cholesky). The returned shadow intensity is the sharp lower bound on the fraction in front
// of zf: the weight of the nodes < zf.
struct MomentQuadrature {
  double z[3] = {0, 0, 0};  // z[0] = zf, z[1] <= z[2]
  double w[3] = {0, 0, 0};
  double intensity = 0;     // sum of w[i] over z[i] < zf, clamped to [0, 1]
};
MomentQuadrature hamburger_4msm(const std::array<double, 4>& b, double zf, double alpha);

// Peters, Münstermann, Wetzstein, Klein 2016 (moment soft shadows): the blockers of a
// search region from its four moments. Here from the same quadrature: the nodes in front of
// the receiver and their weights (their weighted mean depth).
BlockerEstimate moment_blockers(const std::array<double, 4>& b, double zf, double alpha);

// Peters & Klein 2015 (their optimized quantization): the power moments (z, z^2, z^3, z^4) as
// the row vector b times the paper's 4 x 4 matrix plus (0.035955884801, 0, 0, 0), which
// keeps every depth's vector inside [0, 1]^4 and spreads the 16-bit quantisation error
// evenly; the inverse transform recovers b after filtering (the transform is affine, so it
// commutes with any normalised filter).
std::array<double, 4> msm_optimize(const std::array<double, 4>& b);
std::array<double, 4> msm_deoptimize(const std::array<double, 4>& q);

// A model record (moments_shared.h FmModel) with the double constants filled in (the robust
// quadrature's biases, the optimized basis and its inverse) and every parameter zero.
shader::FmModel fm_model_constants();
// Rounded to the nearest of 65536 levels in [0, 1] (an RGBA16 UNORM texel).
double quantize_unorm16(double v);

}  // namespace penumbra::filtered_moments
