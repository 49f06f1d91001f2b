// project_to_depth_image (depth_image_walk_shared.h's), and the SIMD kernel of walk_depth_image_packet (one inner node
// for every ray of a packet). Highway compiles the kernel once per target (foreach_target)
// and dispatches to the best one the CPU supports; it does the single-ray walk's float
// operations in the same order (no fused multiply-add, comparisons and selects for
// std::min/max), so every target gives the same bits.
#include "penumbra/raster/depth_image_walk.h"

#include <algorithm>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "penumbra/raster/depth_image_walk.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace penumbra {
namespace depth_walk_detail {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void SplitPacketNode(const PacketRays& rays, const PacketNodeInput& in, PacketNodeOutput* out) {
  constexpr int K = kDepthWalkPacket;
  const hn::CappedTag<float, K> d;
  const int N = static_cast<int>(hn::Lanes(d));
  const auto lo = hn::Set(d, in.lo), hi = hn::Set(d, in.hi), zero = hn::Zero(d);
  const auto xm = hn::Set(d, in.xm), ym = hn::Set(d, in.ym);
  const auto all = hn::FirstN(d, static_cast<size_t>(N)), none = hn::FirstN(d, 0);
  const auto has_x1 = in.has_x1 ? all : none, has_y1 = in.has_y1 ? all : none;
  const auto inf = hn::Set(d, hwy::HighestValue<float>());
  for (int c = 0; c < 4; ++c) out->rays[c] = 0, out->first[c] = hwy::HighestValue<float>();
  for (int i = 0; i < K; i += N) {
    const uint32_t lane_rays = in.rays >> i;
    const uint8_t active_bits[8] = {static_cast<uint8_t>(lane_rays), static_cast<uint8_t>(lane_rays >> 8), 0, 0, 0, 0, 0, 0};
    const auto active = hn::LoadMaskBits(d, active_bits);
    const auto ta = hn::LoadU(d, in.ta + i), tb = hn::LoadU(d, in.tb + i);
    auto a = ta, b = tb;
    auto pass = all;
    if (in.minmax_clipping) {
      // clip_axis(d0, dd, id, lo, hi, &a, &b)
      const auto d0 = hn::LoadU(d, rays.d0 + i), dd = hn::LoadU(d, rays.dd + i), id = hn::LoadU(d, rays.id + i);
      const auto u = hn::Mul(hn::Sub(lo, d0), id), v = hn::Mul(hn::Sub(hi, d0), id);
      const auto sw = hn::Gt(u, v);
      const auto u2 = hn::IfThenElse(sw, v, u), v2 = hn::IfThenElse(sw, u, v);
      const auto ca = hn::IfThenElse(hn::Lt(ta, u2), u2, ta), cb = hn::IfThenElse(hn::Lt(v2, tb), v2, tb);
      const auto flat = hn::Eq(dd, zero);
      a = hn::IfThenElse(flat, ta, ca);
      b = hn::IfThenElse(flat, tb, cb);
      const auto flat_pass = hn::And(hn::And(hn::Ge(d0, lo), hn::Le(d0, hi)), hn::Le(ta, tb));
      pass = hn::Or(hn::And(flat, flat_pass), hn::AndNot(flat, hn::Le(ca, cb)));
    } else {
      pass = hn::Ne(hn::LoadU(d, in.pass + i), zero);
    }
    hn::StoreU(a, d, out->a + i);
    hn::StoreU(b, d, out->b + i);
    // split_axis per axis at the node's midlines.
    const auto px = hn::LoadU(d, rays.px + i), py = hn::LoadU(d, rays.py + i);
    const auto dx = hn::LoadU(d, rays.dx + i), dy = hn::LoadU(d, rays.dy + i);
    const auto tx = hn::Mul(hn::Sub(xm, px), hn::LoadU(d, rays.ix + i));
    const auto ty = hn::Mul(hn::Sub(ym, py), hn::LoadU(d, rays.iy + i));
    const auto lo_x = hn::IfThenElse(hn::Lt(a, tx), tx, a), hi_x = hn::IfThenElse(hn::Lt(tx, b), tx, b);
    const auto lo_y = hn::IfThenElse(hn::Lt(a, ty), ty, a), hi_y = hn::IfThenElse(hn::Lt(ty, b), ty, b);
    const auto xp = hn::And(has_x1, hn::Gt(dx, zero)), xn = hn::And(has_x1, hn::Lt(dx, zero));
    const auto yp = hn::And(has_y1, hn::Gt(dy, zero)), yn = hn::And(has_y1, hn::Lt(dy, zero));
    const auto xs = hn::Or(hn::Gt(dx, zero), hn::Lt(dx, zero)), ys = hn::Or(hn::Gt(dy, zero), hn::Lt(dy, zero));
    const decltype(a) xa[2] = {hn::IfThenElse(xn, lo_x, a), hn::IfThenElse(xp, lo_x, a)};
    const decltype(a) xb[2] = {hn::IfThenElse(xp, hi_x, b), hn::IfThenElse(xn, hi_x, b)};
    const decltype(a) ya[2] = {hn::IfThenElse(yn, lo_y, a), hn::IfThenElse(yp, lo_y, a)};
    const decltype(a) yb[2] = {hn::IfThenElse(yp, hi_y, b), hn::IfThenElse(yn, hi_y, b)};
    const decltype(pass) xin[2] = {hn::Or(hn::Not(has_x1), hn::Or(xs, hn::Le(px, xm))),
                                   hn::And(has_x1, hn::Or(xs, hn::Ge(px, xm)))};
    const decltype(pass) yin[2] = {hn::Or(hn::Not(has_y1), hn::Or(ys, hn::Le(py, ym))),
                                   hn::And(has_y1, hn::Or(ys, hn::Ge(py, ym)))};
    for (int c = 0; c < 4; ++c) {
      const int cx = c & 1, cy = c >> 1;
      const auto u = hn::IfThenElse(hn::Lt(xa[cx], ya[cy]), ya[cy], xa[cx]);
      const auto v = hn::IfThenElse(hn::Lt(yb[cy], xb[cx]), yb[cy], xb[cx]);
      const auto ok = hn::And(hn::And(hn::And(active, pass), hn::And(xin[cx], yin[cy])), hn::Le(u, v));
      hn::StoreU(u, d, out->ka[c] + i);
      hn::StoreU(v, d, out->kb[c] + i);
      uint8_t bits[8] = {0};
      hn::StoreMaskBits(d, ok, bits);
      out->rays[c] |= (static_cast<uint32_t>(bits[0]) | static_cast<uint32_t>(bits[1]) << 8) << i;
      out->first[c] = std::min(out->first[c], hn::GetLane(hn::MinOfLanes(d, hn::IfThenElse(ok, u, inf))));
    }
  }
}

}  // namespace HWY_NAMESPACE
}  // namespace depth_walk_detail
}  // namespace penumbra
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace penumbra {

namespace depth_walk_detail {
HWY_EXPORT(SplitPacketNode);

void split_packet_node(const PacketRays& rays, const PacketNodeInput& in, PacketNodeOutput* out) {
  HWY_DYNAMIC_DISPATCH(SplitPacketNode)(rays, in, out);
}
}  // namespace depth_walk_detail

bool project_to_depth_image(const LightView& view, Vec3f a, Vec3f b, ProjectedSegment* out) {
  shader::DepthProjection p;
  if (!shader::depth_image_project(view.shared(), a, b, p)) return false;
  *out = ProjectedSegment(p);
  return true;
}

}  // namespace penumbra
#endif  // HWY_ONCE
