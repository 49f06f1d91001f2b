// filter_pairs (pair_filter.h): Highway, compiled once per SIMD target and dispatched at run
// time. No fused multiply-adds (the pragmas below, clang's and g++'s): every product and sum
// is rounded as in the scalar test, so the survivors and their lines are the scalar code's bit
// for bit.
#if defined(__clang__)
#pragma clang fp contract(off)
#else
#pragma GCC optimize("fp-contract=off")
#endif

#include "penumbra/shadow/alias_free/pair_filter.h"

#include <bit>
#include <cmath>
#include <cstring>

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "penumbra/shadow/alias_free/pair_filter.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace penumbra::afsm {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

size_t FilterPairs(const PairLight& light, const PairCaster& t, const PairSamples& s, uint32_t begin, uint32_t end,
                   PairSurvivor* out, size_t* tested) {
  const hn::ScalableTag<float> d;
  const hn::RebindToUnsigned<decltype(d)> du;
  using V = hn::Vec<decltype(d)>;
  constexpr size_t kMaxLanes = 64;
  const size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d);
  const V v0x = hn::Set(d, t.v[0][0]), v0y = hn::Set(d, t.v[0][1]), v0z = hn::Set(d, t.v[0][2]);
  const V nx = hn::Set(d, t.normal[0]), ny = hn::Set(d, t.normal[1]), nz = hn::Set(d, t.normal[2]);
  const V flat_scale = hn::Set(d, t.flat_scale);
  const V cx = hn::Set(d, light.c[0]), cy = hn::Set(d, light.c[1]), cz = hn::Set(d, light.c[2]);
  const V lsx = hn::Set(d, light.ls[0]), lsy = hn::Set(d, light.ls[1]), lsz = hn::Set(d, light.ls[2]);
  const V ltx = hn::Set(d, light.lt[0]), lty = hn::Set(d, light.lt[1]), ltz = hn::Set(d, light.lt[2]);
  const V md2 = hn::Set(d, light.max_distance2);
  const SampleGrid::Geometry& grid = light.grid;
  const V reach = hn::Set(d, grid.reach);
  const V grid_x0 = hn::Set(d, grid.x0), grid_y0 = hn::Set(d, grid.y0), grid_x1 = hn::Set(d, grid.x1),
          grid_y1 = hn::Set(d, grid.y1), inv_w = hn::Set(d, grid.inv_w), inv_h = hn::Set(d, grid.inv_h);
  const V last_cell = hn::Set(d, static_cast<float>(grid.cells - 1));
  const V max_cells = hn::Set(d, static_cast<float>(light.max_grid_cells));
  HWY_ALIGN float lane_side[kMaxLanes], lane_g[3][2][kMaxLanes], lane_h[3][kMaxLanes], lane_cell[4][kMaxLanes];
  size_t n_out = 0, n_tested = 0;
  for (uint32_t i = begin; i < end; i += static_cast<uint32_t>(lanes)) {
    const auto valid = hn::FirstN(d, end - i);
    auto active = hn::And(valid, hn::RebindMask(d, hn::Eq(hn::LoadU(du, s.settled + i), hn::Zero(du))));
    if (hn::AllFalse(d, active)) continue;
    n_tested += hn::CountTrue(d, active);
    const V px = hn::LoadU(d, s.x + i), py = hn::LoadU(d, s.y + i), pz = hn::LoadU(d, s.z + i);
    // side = dot(normal, p - v0); the edge-on threshold kFlat^2 |normal|^2 |p - v0|^2.
    const V tx = hn::Sub(px, v0x), ty = hn::Sub(py, v0y), tz = hn::Sub(pz, v0z);
    const V side = hn::Add(hn::Add(hn::Mul(nx, tx), hn::Mul(ny, ty)), hn::Mul(nz, tz));
    const V flat2 = hn::Mul(flat_scale, hn::Add(hn::Add(hn::Mul(tx, tx), hn::Mul(ty, ty)), hn::Mul(tz, tz)));
    const auto front = hn::Gt(side, zero);
    // Closed: only with p in front; open: from either side, not in the plane; not edge-on.
    active = hn::And(active, t.closed ? front : hn::Not(hn::Eq(side, zero)));
    active = hn::And(active, hn::Gt(hn::Mul(side, side), flat2));
    if (hn::AllFalse(d, active)) continue;
    const V cpx = hn::Sub(cx, px), cpy = hn::Sub(cy, py), cpz = hn::Sub(cz, pz);
    V g[3][2], h[3];
    auto cuts = active;  // every line cuts the samples' disk (else not a bounded triangle)
    for (int k = 0; k < 3; ++k) {
      // e = cross(d, a) (a = v_k - p) when p is in front, cross(a, d) = -cross(d, a) otherwise.
      const V ax = hn::Sub(hn::Set(d, t.v[k][0]), px), ay = hn::Sub(hn::Set(d, t.v[k][1]), py),
              az = hn::Sub(hn::Set(d, t.v[k][2]), pz);
      const V dx = hn::Set(d, t.d[k][0]), dy = hn::Set(d, t.d[k][1]), dz = hn::Set(d, t.d[k][2]);
      V ex = hn::Sub(hn::Mul(dy, az), hn::Mul(dz, ay));
      V ey = hn::Sub(hn::Mul(dz, ax), hn::Mul(dx, az));
      V ez = hn::Sub(hn::Mul(dx, ay), hn::Mul(dy, ax));
      ex = hn::IfThenElse(front, ex, hn::Neg(ex));
      ey = hn::IfThenElse(front, ey, hn::Neg(ey));
      ez = hn::IfThenElse(front, ez, hn::Neg(ez));
      V gx = hn::Add(hn::Add(hn::Mul(ex, lsx), hn::Mul(ey, lsy)), hn::Mul(ez, lsz));
      V gy = hn::Add(hn::Add(hn::Mul(ex, ltx), hn::Mul(ey, lty)), hn::Mul(ez, ltz));
      if (s.rot_c) {  // rotate(g, r) = (r.x g.x + r.y g.y, -r.y g.x + r.x g.y)
        const V rc = hn::LoadU(d, s.rot_c + i), rs = hn::LoadU(d, s.rot_s + i);
        const V rx = hn::Add(hn::Mul(rc, gx), hn::Mul(rs, gy));
        const V ry = hn::Add(hn::Mul(hn::Neg(rs), gx), hn::Mul(rc, gy));
        gx = rx, gy = ry;
      }
      const V hk = hn::Add(hn::Add(hn::Mul(ex, cpx), hn::Mul(ey, cpy)), hn::Mul(ez, cpz));
      // PlaneMaskLut::side_of_disk < 0: no light sample on the plane's inner side.
      const V g2 = hn::Add(hn::Mul(gx, gx), hn::Mul(gy, gy));
      const auto g_zero = hn::Eq(g2, zero);
      const auto outside = hn::Or(hn::Gt(hn::Mul(hk, hk), hn::Mul(g2, md2)), hn::And(g_zero, hn::Not(hn::Eq(hk, zero))));
      const auto misses = hn::Or(hn::And(outside, hn::Not(hn::Gt(hk, zero))), hn::And(hn::Not(outside), g_zero));
      active = hn::And(active, hn::Not(misses));
      cuts = hn::And(cuts, hn::Not(outside));
      g[k][0] = gx, g[k][1] = gy, h[k] = hk;
    }
    if (hn::AllFalse(d, active)) continue;
    // SampleGrid::triangle_cells in float. above() puts a sample on a line's positive side
    // only if g . u + h >= -2^-22 S exactly (S = (|g.x| + |g.y|) reach + |h|): relax each line
    // by 2^-18 S (h' = h + that, rounding included). The relaxed lines bound a triangle iff
    // the cross products of consecutive normals share a sign; each c is trusted only when
    // |c| > 2^-12 B (B = the sum of its products' magnitudes, c's rounding <= 2^-23 B). A
    // vertex x = N / c is then within E = 2^-20 ((A + |x| B) / |c| + |x|) of the exact one
    // (A: N's products' magnitudes; 8 times the first-order rounding bound).
    uint8_t grid_bits[kMaxLanes / 8] = {};  // lanes on the grid, with their cells
    if (!hn::AllFalse(d, hn::And(active, cuts))) {
      V hr[3];
      for (int k = 0; k < 3; ++k) {
        const V s_k = hn::Add(hn::Mul(hn::Add(hn::Abs(g[k][0]), hn::Abs(g[k][1])), reach), hn::Abs(h[k]));
        hr[k] = hn::Add(h[k], hn::Mul(hn::Set(d, 0x1p-18f), s_k));
      }
      V c[3], b[3];
      for (int k = 0; k < 3; ++k) {
        const int j = (k + 1) % 3;
        const V p0 = hn::Mul(g[k][0], g[j][1]), p1 = hn::Mul(g[k][1], g[j][0]);
        c[k] = hn::Sub(p0, p1);
        b[k] = hn::Add(hn::Abs(p0), hn::Abs(p1));
      }
      const V eps12 = hn::Set(d, 0x1p-12f), eps20 = hn::Set(d, 0x1p-20f);
      auto bounded = hn::Or(hn::And(hn::And(hn::Gt(c[0], zero), hn::Gt(c[1], zero)), hn::Gt(c[2], zero)),
                            hn::And(hn::And(hn::Lt(c[0], zero), hn::Lt(c[1], zero)), hn::Lt(c[2], zero)));
      for (int k = 0; k < 3; ++k) bounded = hn::And(bounded, hn::Gt(hn::Abs(c[k]), hn::Mul(eps12, b[k])));
      const V inf = hn::Set(d, HUGE_VALF);
      V bx0 = inf, by0 = inf, bx1 = hn::Neg(inf), by1 = hn::Neg(inf);
      for (int k = 0; k < 3; ++k) {
        const int j = (k + 1) % 3;
        const V qx0 = hn::Mul(hr[j], g[k][1]), qx1 = hn::Mul(hr[k], g[j][1]);
        const V qy0 = hn::Mul(hr[k], g[j][0]), qy1 = hn::Mul(hr[j], g[k][0]);
        // (x = N * (1 / c): one more rounding, 2^-24 |x|, well inside E's 2^-20 |x|.)
        const V r = hn::Div(hn::Set(d, 1.0f), c[k]);
        const V x = hn::Mul(hn::Sub(qx0, qx1), r), y = hn::Mul(hn::Sub(qy0, qy1), r);
        const V inv_c = hn::Abs(r);
        const V ex = hn::Mul(eps20, hn::Add(hn::Mul(hn::Add(hn::Add(hn::Abs(qx0), hn::Abs(qx1)),
                                                             hn::Mul(hn::Abs(x), b[k])), inv_c), hn::Abs(x)));
        const V ey = hn::Mul(eps20, hn::Add(hn::Mul(hn::Add(hn::Add(hn::Abs(qy0), hn::Abs(qy1)),
                                                             hn::Mul(hn::Abs(y), b[k])), inv_c), hn::Abs(y)));
        bx0 = hn::Min(bx0, hn::Sub(x, ex)), bx1 = hn::Max(bx1, hn::Add(x, ex));
        by0 = hn::Min(by0, hn::Sub(y, ey)), by1 = hn::Max(by1, hn::Add(y, ey));
      }
      // Finite bounds only (x - x is 0 exactly for finite x, NaN otherwise).
      bounded = hn::And(bounded, hn::Eq(hn::Sub(bx1, bx0), hn::Sub(bx1, bx0)));
      bounded = hn::And(bounded, hn::Eq(hn::Sub(by1, by0), hn::Sub(by1, by0)));
      bounded = hn::And(bounded, hn::Lt(hn::Abs(hn::Add(hn::Abs(bx0), hn::Abs(bx1))), inf));
      bounded = hn::And(bounded, hn::Lt(hn::Abs(hn::Add(hn::Abs(by0), hn::Abs(by1))), inf));
      bounded = hn::And(bounded, cuts);
      // A bounded triangle beside every sample: nothing to test.
      const auto beside = hn::Or(hn::Or(hn::Lt(bx1, grid_x0), hn::Gt(bx0, grid_x1)),
                                 hn::Or(hn::Lt(by1, grid_y0), hn::Gt(by0, grid_y1)));
      active = hn::AndNot(hn::And(bounded, beside), active);
      if (hn::AllFalse(d, active)) continue;
      // SampleGrid::cell_x / cell_y (the same rounded operations: monotone, so a sample between
      // two bounds is in a cell between theirs), clamped to the grid.
      auto to_cell = [&](V u, V origin, V inv) {
        return hn::Floor(hn::Min(hn::Max(hn::Mul(hn::Sub(u, origin), inv), zero), last_cell));
      };
      const V cx0 = to_cell(bx0, grid_x0, inv_w), cx1 = to_cell(bx1, grid_x0, inv_w);
      const V cy0 = to_cell(by0, grid_y0, inv_h), cy1 = to_cell(by1, grid_y0, inv_h);
      const V cell_count = hn::Mul(hn::Add(hn::Sub(cx1, cx0), hn::Set(d, 1.0f)), hn::Add(hn::Sub(cy1, cy0), hn::Set(d, 1.0f)));
      const auto on_grid = hn::And(bounded, hn::Not(hn::Gt(cell_count, max_cells)));
      // Small ranges (one or two rows of at most 4 samples each): test their samples here, so
      // that only pairs with a sample inside all three lines go on (most tiny projected
      // triangles fall between the samples).
      auto small = hn::And(on_grid, hn::Not(hn::Gt(hn::Sub(cy1, cy0), hn::Set(d, 1.0f))));
      if (!hn::AllFalse(d, small)) {
        const hn::RebindToSigned<decltype(d)> di;
        using VI = hn::Vec<decltype(di)>;
        const int32_t* first = reinterpret_cast<const int32_t*>(light.samples->first());
        const VI cells = hn::Set(di, grid.cells), one = hn::Set(di, 1), four = hn::Set(di, 4);
        const auto small_i = hn::RebindMask(di, small);
        const VI ix0 = hn::ConvertTo(di, cx0), ix1 = hn::ConvertTo(di, cx1), iy0 = hn::ConvertTo(di, cy0),
                 iy1 = hn::ConvertTo(di, cy1);
        const VI zero_i = hn::Zero(di);
        const VI base0 = hn::IfThenElseZero(small_i, hn::Mul(iy0, cells));
        const auto two_rows = hn::And(small_i, hn::Gt(iy1, iy0));
        const VI base1 = hn::IfThenElse(two_rows, hn::Add(base0, cells), base0);
        const VI col0 = hn::IfThenElseZero(small_i, ix0), col1 = hn::IfThenElseZero(small_i, hn::Add(ix1, one));
        const VI kb[2] = {hn::GatherIndex(di, first, hn::Add(base0, col0)), hn::GatherIndex(di, first, hn::Add(base1, col0))};
        const VI ke0 = hn::GatherIndex(di, first, hn::Add(base0, col1));
        const VI ke[2] = {ke0, hn::IfThenElse(two_rows, hn::GatherIndex(di, first, hn::Add(base1, col1)), kb[1])};
        const VI count[2] = {hn::Sub(ke[0], kb[0]), hn::Sub(ke[1], kb[1])};
        auto tested_here = hn::And(small_i, hn::And(hn::Not(hn::Gt(count[0], four)), hn::Not(hn::Gt(count[1], four))));
        auto any_inside = hn::Not(hn::Gt(one, zero_i));  // all false
        for (int row = 0; row < 2; ++row)
          for (int j = 0; j < 4; ++j) {
            const auto valid = hn::And(tested_here, hn::Gt(count[row], hn::Set(di, j)));
            if (hn::AllFalse(di, valid)) break;
            const VI k = hn::IfThenElseZero(valid, hn::Add(kb[row], hn::Set(di, j)));
            const V ux = hn::GatherIndex(d, light.samples->x(), k), uy = hn::GatherIndex(d, light.samples->y(), k);
            auto in = hn::RebindMask(d, valid);
            for (int e = 0; e < 3; ++e)  // above(): (ux g.x + uy g.y) + h > 0
              in = hn::And(in, hn::Gt(hn::Add(hn::Add(hn::Mul(ux, g[e][0]), hn::Mul(uy, g[e][1])), h[e]), zero));
            any_inside = hn::Or(any_inside, hn::RebindMask(di, in));
          }
        active = hn::AndNot(hn::RebindMask(d, hn::AndNot(any_inside, tested_here)), active);
        if (hn::AllFalse(d, active)) continue;
      }
      hn::Store(cx0, d, lane_cell[0]);
      hn::Store(cy0, d, lane_cell[1]);
      hn::Store(cx1, d, lane_cell[2]);
      hn::Store(cy1, d, lane_cell[3]);
      hn::StoreMaskBits(d, on_grid, grid_bits);
    }
    hn::Store(side, d, lane_side);
    for (int k = 0; k < 3; ++k) {
      hn::Store(g[k][0], d, lane_g[k][0]);
      hn::Store(g[k][1], d, lane_g[k][1]);
      hn::Store(h[k], d, lane_h[k]);
    }
    uint8_t bits[kMaxLanes / 8] = {};
    hn::StoreMaskBits(d, active, bits);
    for (size_t j = 0; j < lanes; ++j) {
      if (!((bits[j >> 3] >> (j & 7)) & 1)) continue;
      PairSurvivor& o = out[n_out++];
      o.slot = i + static_cast<uint32_t>(j);
      o.side = lane_side[j];
      for (int k = 0; k < 3; ++k) o.edges[k] = {{lane_g[k][0][j], lane_g[k][1][j]}, lane_h[k][j]};
      o.on_grid = (grid_bits[j >> 3] >> (j & 7)) & 1;
      o.x0 = o.y0 = 0, o.x1 = o.y1 = -1;
      if (o.on_grid) {
        o.x0 = static_cast<int32_t>(lane_cell[0][j]), o.y0 = static_cast<int32_t>(lane_cell[1][j]);
        o.x1 = static_cast<int32_t>(lane_cell[2][j]), o.y1 = static_cast<int32_t>(lane_cell[3][j]);
      }
    }
  }
  *tested = n_tested;
  return n_out;
}

size_t InsideCells(const SampleGrid& grid, const SampleGrid::Range& r, const Line edges[3], uint32_t* out) {
  const hn::ScalableTag<float> d;
  using V = hn::Vec<decltype(d)>;
  const size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d);
  V gx[3], gy[3], h[3];
  for (int k = 0; k < 3; ++k)
    gx[k] = hn::Set(d, edges[k].g.x), gy[k] = hn::Set(d, edges[k].g.y), h[k] = hn::Set(d, edges[k].h);
  size_t n = 0;
  for (int y = r.y0; y <= r.y1; ++y) {
    const uint32_t k_end = grid.row_end(y, r.x1);
    for (uint32_t k = grid.row_begin(y, r.x0); k < k_end; k += static_cast<uint32_t>(lanes)) {
      const V ux = hn::LoadU(d, grid.x() + k), uy = hn::LoadU(d, grid.y() + k);
      auto inside = hn::FirstN(d, k_end - k);
      for (int j = 0; j < 3; ++j)  // above(): (ux g.x + uy g.y) + h > 0
        inside = hn::And(inside, hn::Gt(hn::Add(hn::Add(hn::Mul(ux, gx[j]), hn::Mul(uy, gy[j])), h[j]), zero));
      // (The set lanes one by one: a compressing store to memory is slow on some CPUs.)
      uint8_t bits[8] = {};
      hn::StoreMaskBits(d, inside, bits);
      uint64_t word;
      std::memcpy(&word, bits, sizeof(word));
      for (; word; word &= word - 1) out[n++] = k + static_cast<uint32_t>(std::countr_zero(word));
    }
  }
  return n;
}

// NOLINTNEXTLINE(google-readability-namespace-comments)
}  // namespace HWY_NAMESPACE
}  // namespace penumbra::afsm
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace penumbra::afsm {

HWY_EXPORT(FilterPairs);
HWY_EXPORT(InsideCells);

size_t inside_cells(const SampleGrid& grid, const SampleGrid::Range& r, const Line edges[3], uint32_t* out) {
  return HWY_DYNAMIC_DISPATCH(InsideCells)(grid, r, edges, out);
}

size_t filter_pairs(const PairLight& light, const PairCaster& caster, const PairSamples& samples, uint32_t begin,
                    uint32_t end, PairSurvivor* out, size_t* tested) {
  return HWY_DYNAMIC_DISPATCH(FilterPairs)(light, caster, samples, begin, end, out, tested);
}

}  // namespace penumbra::afsm
#endif  // HWY_ONCE
