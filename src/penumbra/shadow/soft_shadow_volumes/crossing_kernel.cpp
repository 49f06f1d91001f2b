// add_crossings (crossing_kernel.h): Highway, one copy per SIMD target. No fused multiply-adds
// (the pragmas below, clang's and g++'s): every target rounds each product and sum alike.
#if defined(__clang__)
#pragma clang fp contract(off)
#else
#pragma GCC optimize("fp-contract=off")
#endif

#include "penumbra/shadow/soft_shadow_volumes/crossing_kernel.h"

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "penumbra/shadow/soft_shadow_volumes/crossing_kernel.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace penumbra::ssv {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void AddCrossings(const CrossingTests& c, const float* x, const float* y, const float* z, size_t padded,
                  int32_t delta, int32_t* depth) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  using V = hn::Vec<decltype(d)>;
  const V mx = hn::Set(d, c.m[0]), my = hn::Set(d, c.m[1]), mz = hn::Set(d, c.m[2]);
  const V ux = hn::Set(d, c.u[0]), uy = hn::Set(d, c.u[1]), uz = hn::Set(d, c.u[2]), ua = hn::Set(d, c.ua);
  const V ax = hn::Set(d, c.alpha[0]), ay = hn::Set(d, c.alpha[1]), az = hn::Set(d, c.alpha[2]);
  const V bx = hn::Set(d, c.beta[0]), by = hn::Set(d, c.beta[1]), bz = hn::Set(d, c.beta[2]);
  const V zero = hn::Zero(d);
  const auto vdelta = hn::Set(di, delta);
  const size_t lanes = hn::Lanes(d);
  for (size_t i = 0; i < padded; i += lanes) {
    const V X = hn::LoadU(d, x + i), Y = hn::LoadU(d, y + i), Z = hn::LoadU(d, z + i);
    const V s = hn::Add(hn::Add(hn::Mul(mx, X), hn::Mul(my, Y)), hn::Mul(mz, Z));
    const V t = hn::Sub(hn::Add(hn::Add(hn::Mul(ux, X), hn::Mul(uy, Y)), hn::Mul(uz, Z)), ua);
    const V pa = hn::Add(hn::Add(hn::Mul(ax, X), hn::Mul(ay, Y)), hn::Mul(az, Z));
    const V pb = hn::Add(hn::Add(hn::Mul(bx, X), hn::Mul(by, Y)), hn::Mul(bz, Z));
    // pa pb < 0: opposite signs, neither 0 (a product that underflows to 0 is a sample on
    // the plane: no crossing).
    const auto crosses = hn::And(hn::And(hn::Lt(s, zero), hn::Gt(t, zero)), hn::Lt(hn::Mul(pa, pb), zero));
    const auto current = hn::LoadU(di, depth + i);
    hn::StoreU(hn::IfThenElse(hn::RebindMask(di, crosses), hn::Add(current, vdelta), current), di, depth + i);
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace penumbra::ssv
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace penumbra::ssv {

HWY_EXPORT(AddCrossings);

void add_crossings(const CrossingTests& tests, const float* x, const float* y, const float* z, size_t padded,
                   int32_t delta, int32_t* depth) {
  HWY_DYNAMIC_DISPATCH(AddCrossings)(tests, x, y, z, padded, delta, depth);
}

}  // namespace penumbra::ssv
#endif  // HWY_ONCE
