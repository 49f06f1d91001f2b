// SIMD kernels of light_batch.h. Highway compiles this file once per target (foreach_target)
// and dispatches to the best one the CPU supports; the scalar code they mirror is
// LightPointSampler::sample in light.cpp (keep the two in step).
#include "penumbra/scene/light_batch.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "penumbra/scene/light_batch.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>
#include <hwy/contrib/math/math-inl.h>

HWY_BEFORE_NAMESPACE();
namespace penumbra {
namespace light_kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void SampleSphericalRect(const SphericalRect& r, const float* HWY_RESTRICT ux, const float* HWY_RESTRICT uy, size_t n,
                         float* HWY_RESTRICT ox, float* HWY_RESTRICT oy, float* HWY_RESTRICT oz,
                         float* HWY_RESTRICT odist, float* HWY_RESTRICT oinv_pdf, float* HWY_RESTRICT oweight) {
  const hn::ScalableTag<float> d;
  const auto one = hn::Set(d, 1.0f), zero = hn::Zero(d);
  const auto S = hn::Set(d, r.solid_angle), K = hn::Set(d, r.k);
  const auto b0 = hn::Set(d, r.b0), b1 = hn::Set(d, r.b1), b0sq = hn::Set(d, r.b0 * r.b0);
  const auto z0 = hn::Set(d, r.z0), z0sq = hn::Set(d, r.z0 * r.z0), abs_z0 = hn::Set(d, std::abs(r.z0));
  const auto x0 = hn::Set(d, r.x0), x1 = hn::Set(d, r.x1), y0 = hn::Set(d, r.y0), y1 = hn::Set(d, r.y1);
  const auto y0sq = hn::Set(d, r.y0 * r.y0), y1sq = hn::Set(d, r.y1 * r.y1);
  const auto weight_scale = hn::Set(d, r.solid_angle * r.inv_area);
  const auto z0x = hn::Set(d, r.z[0] * r.z0), z0y = hn::Set(d, r.z[1] * r.z0), z0z = hn::Set(d, r.z[2] * r.z0);
  const auto Xx = hn::Set(d, r.x[0]), Xy = hn::Set(d, r.x[1]), Xz = hn::Set(d, r.x[2]);
  const auto Yx = hn::Set(d, r.y[0]), Yy = hn::Set(d, r.y[1]), Yz = hn::Set(d, r.y[2]);
  for (size_t i = 0; i < n; i += hn::Lanes(d)) {
    // Urena et al. 2013, Algorithm 1: u.x picks the azimuthal slice by solid angle...
    const auto au = hn::MulAdd(hn::LoadU(d, ux + i), S, K);
    const auto fu = hn::Div(hn::MulSub(hn::Cos(d, au), b0, b1), hn::Sin(d, au));
    auto cu = hn::Div(hn::CopySign(one, fu), hn::Sqrt(hn::MulAdd(fu, fu, b0sq)));
    cu = hn::Min(hn::Max(cu, hn::Neg(one)), one);
    auto xu = hn::Div(hn::Neg(hn::Mul(cu, z0)), hn::Sqrt(hn::Max(hn::Set(d, 1e-12f), hn::NegMulAdd(cu, cu, one))));
    xu = hn::Min(hn::Max(xu, x0), x1);
    // ...and u.y the height along it, uniform in the cosine of the elevation.
    const auto dd2 = hn::MulAdd(xu, xu, z0sq);
    const auto dd = hn::Sqrt(dd2);
    const auto h0 = hn::Div(y0, hn::Sqrt(hn::Add(dd2, y0sq)));
    const auto h1 = hn::Div(y1, hn::Sqrt(hn::Add(dd2, y1sq)));
    const auto hv = hn::MulAdd(hn::LoadU(d, uy + i), hn::Sub(h1, h0), h0);
    const auto one_minus_hv2 = hn::NegMulAdd(hv, hv, one);
    // Lanes with hv^2 >= 1 - 1e-6 take y1 (their quotient is discarded).
    auto yv = hn::IfThenElse(hn::Gt(one_minus_hv2, hn::Set(d, 1e-6f)),
                             hn::Div(hn::Mul(hv, dd), hn::Sqrt(hn::Max(one_minus_hv2, hn::Set(d, 1e-30f)))), y1);
    yv = hn::Min(hn::Max(yv, y0), y1);
    // The light point in world space, relative to p: x xu + y yv + z z0.
    const auto wx = hn::MulAdd(Xx, xu, hn::MulAdd(Yx, yv, z0x));
    const auto wy = hn::MulAdd(Xy, xu, hn::MulAdd(Yy, yv, z0y));
    const auto wz = hn::MulAdd(Xz, xu, hn::MulAdd(Yz, yv, z0z));
    const auto dist2 = hn::MulAdd(yv, yv, dd2);
    const auto dist = hn::Sqrt(dist2);
    // area_weight = p_A / p_omega = dist^2 / (A cos_l) * Omega with cos_l = |z0| / dist;
    // zero where the light is seen edge-on (cos_l <= 1e-8), as in the scalar sampler.
    const auto edge_on = hn::Le(abs_z0, hn::Mul(hn::Set(d, 1e-8f), dist));
    const auto weight = hn::IfThenZeroElse(
        edge_on, hn::Div(hn::Mul(hn::Mul(dist2, dist), weight_scale), hn::Max(abs_z0, hn::Set(d, 1e-30f))));
    hn::StoreU(wx, d, ox + i);
    hn::StoreU(wy, d, oy + i);
    hn::StoreU(wz, d, oz + i);
    hn::StoreU(dist, d, odist + i);
    hn::StoreU(S, d, oinv_pdf + i);
    hn::StoreU(weight, d, oweight + i);
  }
  (void)zero;
}

void SampleCone(const Cone& c, const float* HWY_RESTRICT ux, const float* HWY_RESTRICT uy, size_t n,
                float* HWY_RESTRICT ox, float* HWY_RESTRICT oy, float* HWY_RESTRICT oz, float* HWY_RESTRICT odist,
                float* HWY_RESTRICT oinv_pdf, float* HWY_RESTRICT oweight) {
  const hn::ScalableTag<float> d;
  const auto one = hn::Set(d, 1.0f), zero = hn::Zero(d);
  const auto cos_max = hn::Set(d, c.cos_max), two_pi = hn::Set(d, 6.28318530717958647692f);
  const auto sx = hn::Set(d, c.s[0]), sy = hn::Set(d, c.s[1]), sz = hn::Set(d, c.s[2]);
  const auto tx = hn::Set(d, c.t[0]), ty = hn::Set(d, c.t[1]), tz = hn::Set(d, c.t[2]);
  const auto nx = hn::Set(d, c.n[0]), ny = hn::Set(d, c.n[1]), nz = hn::Set(d, c.n[2]);
  const auto cx = hn::Set(d, c.to_center[0]), cy = hn::Set(d, c.to_center[1]), cz = hn::Set(d, c.to_center[2]);
  const auto c2r2 = hn::Set(d, c.dist2_minus_r2), inv_pdf = hn::Set(d, c.inv_pdf);
  for (size_t i = 0; i < n; i += hn::Lanes(d)) {
    // square_to_cone (core/sampling.cpp): uniform in solid angle inside the cone.
    const auto u0 = hn::LoadU(d, ux + i);
    const auto cos_t = hn::MulAdd(u0, cos_max, hn::Sub(one, u0));
    const auto sin_t = hn::Sqrt(hn::Max(zero, hn::NegMulAdd(cos_t, cos_t, one)));
    const auto phi = hn::Mul(two_pi, hn::LoadU(d, uy + i));
    const auto lx = hn::Mul(hn::Cos(d, phi), sin_t), ly = hn::Mul(hn::Sin(d, phi), sin_t);
    const auto dx = hn::MulAdd(sx, lx, hn::MulAdd(tx, ly, hn::Mul(nx, cos_t)));
    const auto dy = hn::MulAdd(sy, lx, hn::MulAdd(ty, ly, hn::Mul(ny, cos_t)));
    const auto dz = hn::MulAdd(sz, lx, hn::MulAdd(tz, ly, hn::Mul(nz, cos_t)));
    // The near intersection with the sphere.
    const auto b = hn::MulAdd(dx, cx, hn::MulAdd(dy, cy, hn::Mul(dz, cz)));
    const auto disc = hn::Sub(hn::Mul(b, b), c2r2);
    const auto dist = hn::Sub(b, hn::Sqrt(hn::Max(zero, disc)));
    hn::StoreU(hn::Mul(dx, dist), d, ox + i);
    hn::StoreU(hn::Mul(dy, dist), d, oy + i);
    hn::StoreU(hn::Mul(dz, dist), d, oz + i);
    hn::StoreU(dist, d, odist + i);
    hn::StoreU(inv_pdf, d, oinv_pdf + i);
    hn::StoreU(one, d, oweight + i);  // visibility of a sphere: the fraction of its solid angle
  }
}


void RectIrradiance(const double (*corners)[3], const float* HWY_RESTRICT px, const float* HWY_RESTRICT py,
                    const float* HWY_RESTRICT pz, const float* HWY_RESTRICT nx, const float* HWY_RESTRICT ny,
                    const float* HWY_RESTRICT nz, size_t n, float* HWY_RESTRICT out) {
  const hn::ScalableTag<double> d;
  const hn::Rebind<float, decltype(d)> df;  // half-width float vectors, promoted to double
  const size_t lanes = hn::Lanes(d);
  const auto zero = hn::Zero(d), half_pi = hn::Set(d, 1.5707963267948966);
  for (size_t i = 0; i < n; i += lanes) {
    const auto x = hn::PromoteTo(d, hn::LoadU(df, px + i));
    const auto y = hn::PromoteTo(d, hn::LoadU(df, py + i));
    const auto z = hn::PromoteTo(d, hn::LoadU(df, pz + i));
    const auto ux = hn::PromoteTo(d, hn::LoadU(df, nx + i));
    const auto uy = hn::PromoteTo(d, hn::LoadU(df, ny + i));
    const auto uz = hn::PromoteTo(d, hn::LoadU(df, nz + i));
    // The corners relative to p, and their heights above p's horizon.
    hn::Vec<decltype(d)> ax[4], ay[4], az[4], dn[4];
    for (int k = 0; k < 4; ++k) {
      ax[k] = hn::Sub(hn::Set(d, corners[k][0]), x);
      ay[k] = hn::Sub(hn::Set(d, corners[k][1]), y);
      az[k] = hn::Sub(hn::Set(d, corners[k][2]), z);
      dn[k] = hn::Add(hn::Add(hn::Mul(ax[k], ux), hn::Mul(ay[k], uy)), hn::Mul(az[k], uz));
    }
    // One edge's term theta (n . gamma) / |gamma|, gamma = a x b, theta = atan2(|a x b|, a . b):
    // accurate for the small angles of far lights, where acos(a . b / (|a| |b|)) loses half
    // its digits. Edges through p (|gamma| ~ 0) contribute nothing, as in the scalar formula.
    auto edge_term = [&](auto ax_, auto ay_, auto az_, auto bx, auto by, auto bz) {
      const auto cx = hn::Sub(hn::Mul(ay_, bz), hn::Mul(az_, by));
      const auto cy = hn::Sub(hn::Mul(az_, bx), hn::Mul(ax_, bz));
      const auto cz = hn::Sub(hn::Mul(ax_, by), hn::Mul(ay_, bx));
      const auto lc = hn::Sqrt(hn::Add(hn::Add(hn::Mul(cx, cx), hn::Mul(cy, cy)), hn::Mul(cz, cz)));
      const auto ab = hn::Add(hn::Add(hn::Mul(ax_, bx), hn::Mul(ay_, by)), hn::Mul(az_, bz));
      // atan2(lc, ab) for lc > 0: atan(lc / ab) when ab >= lc, else pi/2 - atan(ab / lc).
      const auto small = hn::Ge(ab, lc);
      const auto safe_lc = hn::Max(lc, hn::Set(d, 1e-300));
      const auto q = hn::IfThenElse(small, hn::Div(lc, hn::Max(ab, hn::Set(d, 1e-300))), hn::Div(ab, safe_lc));
      const auto at = hn::Atan(d, q);
      const auto theta = hn::IfThenElse(small, at, hn::Sub(half_pi, at));
      const auto cn = hn::Add(hn::Add(hn::Mul(cx, ux), hn::Mul(cy, uy)), hn::Mul(cz, uz));
      return hn::IfThenElseZero(hn::Ge(lc, hn::Set(d, 1e-15)), hn::Div(hn::Mul(theta, cn), safe_lc));
    };
    // The rectangle clipped to the hemisphere of n (Sutherland-Hodgman against one plane, as
    // the scalar formula, but edge by edge): an edge with both ends above counts whole, one
    // crossing the horizon counts from its end above to the crossing, one below not at all;
    // the clipped polygon's closing edge runs along the horizon from where the outline leaves
    // the hemisphere to where it enters it again (a convex outline does each at most once).
    auto sum = zero;
    const auto all_above = hn::And(hn::And(hn::Ge(dn[0], zero), hn::Ge(dn[1], zero)),
                                   hn::And(hn::Ge(dn[2], zero), hn::Ge(dn[3], zero)));
    if (hn::AllTrue(d, all_above)) {  // the common case: no lane's horizon cuts the light
      for (int k = 0; k < 4; ++k) {
        const int l = (k + 1) & 3;
        sum = hn::Add(sum, edge_term(ax[k], ay[k], az[k], ax[l], ay[l], az[l]));
      }
      hn::StoreU(hn::DemoteTo(df, hn::Mul(hn::Set(d, 0.5), hn::Abs(sum))), df, out + i);
      continue;
    }
    auto exit_x = zero, exit_y = zero, exit_z = zero, entry_x = zero, entry_y = zero, entry_z = zero;
    auto has_exit = hn::Lt(zero, zero), has_entry = has_exit;
    for (int k = 0; k < 4; ++k) {
      const int l = (k + 1) & 3;
      const auto above_a = hn::Ge(dn[k], zero), above_b = hn::Ge(dn[l], zero);
      const auto crosses = hn::Xor(above_a, above_b);
      const auto denom = hn::Sub(dn[k], dn[l]);
      const auto t = hn::Div(dn[k], hn::IfThenElse(crosses, denom, hn::Set(d, 1.0)));
      const auto ix = hn::Add(ax[k], hn::Mul(t, hn::Sub(ax[l], ax[k])));
      const auto iy = hn::Add(ay[k], hn::Mul(t, hn::Sub(ay[l], ay[k])));
      const auto iz = hn::Add(az[k], hn::Mul(t, hn::Sub(az[l], az[k])));
      const auto term = edge_term(hn::IfThenElse(above_a, ax[k], ix), hn::IfThenElse(above_a, ay[k], iy),
                                  hn::IfThenElse(above_a, az[k], iz), hn::IfThenElse(above_b, ax[l], ix),
                                  hn::IfThenElse(above_b, ay[l], iy), hn::IfThenElse(above_b, az[l], iz));
      sum = hn::Add(sum, hn::IfThenElseZero(hn::Or(above_a, above_b), term));
      const auto leaves = hn::AndNot(above_b, above_a), enters = hn::AndNot(above_a, above_b);
      exit_x = hn::IfThenElse(leaves, ix, exit_x), exit_y = hn::IfThenElse(leaves, iy, exit_y);
      exit_z = hn::IfThenElse(leaves, iz, exit_z), has_exit = hn::Or(has_exit, leaves);
      entry_x = hn::IfThenElse(enters, ix, entry_x), entry_y = hn::IfThenElse(enters, iy, entry_y);
      entry_z = hn::IfThenElse(enters, iz, entry_z), has_entry = hn::Or(has_entry, enters);
    }
    const auto closing = edge_term(exit_x, exit_y, exit_z, entry_x, entry_y, entry_z);
    sum = hn::Add(sum, hn::IfThenElseZero(hn::And(has_exit, has_entry), closing));
    const auto e = hn::Mul(hn::Set(d, 0.5), hn::Abs(sum));
    hn::StoreU(hn::DemoteTo(df, e), df, out + i);
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace light_kernels
}  // namespace penumbra
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace penumbra {

void LightSampleBatch::resize(int n) {
  const size_t size = padded(n);
  for (auto* a : {&x, &y, &z, &dist, &inv_pdf, &area_weight})
    if (a->size() < size) a->resize(size);
}

namespace light_kernels {
HWY_EXPORT(SampleSphericalRect);
HWY_EXPORT(SampleCone);
HWY_EXPORT(RectIrradiance);

void rect_irradiance(const double corners[4][3], const float* px, const float* py, const float* pz,
                     const float* nx, const float* ny, const float* nz, size_t n, float* out) {
  HWY_DYNAMIC_DISPATCH(RectIrradiance)(corners, px, py, pz, nx, ny, nz, n, out);
}

void sample_spherical_rect(const SphericalRect& rect, const float* ux, const float* uy, size_t n,
                           LightSampleBatch& out) {
  HWY_DYNAMIC_DISPATCH(SampleSphericalRect)(rect, ux, uy, n, out.x.data(), out.y.data(), out.z.data(),
                                            out.dist.data(), out.inv_pdf.data(), out.area_weight.data());
}

void sample_cone(const Cone& cone, const float* ux, const float* uy, size_t n, LightSampleBatch& out) {
  HWY_DYNAMIC_DISPATCH(SampleCone)(cone, ux, uy, n, out.x.data(), out.y.data(), out.z.data(), out.dist.data(),
                                   out.inv_pdf.data(), out.area_weight.data());
}
}  // namespace light_kernels
}  // namespace penumbra
#endif  // HWY_ONCE
