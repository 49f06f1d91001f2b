#include "penumbra/raster/depth_image_walk.h"

#include <gtest/gtest.h>
#include <hwy/highway.h>
#include <hwy/targets.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <tuple>
#include <vector>

#include "penumbra/core/rng.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// A smooth depth field with steps, holes (empty texels) and a few spikes: nodes of every
// size pass and fail the overlap test.
std::vector<DepthRange> random_texels(int W, int H, Rng& rng) {
  std::vector<DepthRange> t(size_t(W) * H);
  float fx = 0.05f + 0.2f * rng.next_float(), fy = 0.05f + 0.2f * rng.next_float();
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      float r = rng.next_float();
      if (r < 0.08f) continue;  // empty
      float d = 0.5f + 0.3f * std::sin(fx * x) * std::cos(fy * y) + (x > W / 2 ? 0.1f : 0.0f);
      if (r > 0.97f) d = rng.next_float();
      float thick = rng.next_float() < 0.2f ? 0.05f * rng.next_float() : 0.0f;  // a layered texel
      t[size_t(y) * W + x] = {d, d + thick};
    }
  return t;
}

struct Visit {
  int x, y;
  float ta, tb;
};

// The brute-force march: every texel whose closed square the segment crosses and whose
// range, widened by the tolerance, overlaps the ray's depth over the crossing; sorted by
// entry. `margin` receives, per texel, how far it is from flipping (in t or depth units).
std::vector<Visit> brute_force(int W, int H, const std::vector<DepthRange>& texels, const DepthImageSegment& seg,
                               float tol, std::vector<float>* margins) {
  std::vector<Visit> out;
  margins->assign(texels.size(), kInfinity);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      float a = seg.t0, b = seg.t1;
      const DepthRange& r = texels[size_t(y) * W + x];
      // Distance of the crossing from being empty (negative when it is).
      float ca = seg.t0, cb = seg.t1;
      float box_margin = seg.clip_to_box(float(x), float(y), float(x + 1), float(y + 1), &ca, &cb) ? cb - ca : -1;
      if (!seg.clip_to_box(float(x), float(y), float(x + 1), float(y + 1), &a, &b)) {
        // How close the segment passes: grow the box a little.
        float ga = seg.t0, gb = seg.t1;
        if (seg.clip_to_box(x - 1e-3f, y - 1e-3f, x + 1 + 1e-3f, y + 1 + 1e-3f, &ga, &gb)) (*margins)[size_t(y) * W + x] = 0;
        continue;
      }
      if (r.empty()) continue;
      DepthRange d = seg.depth_over(a, b);
      float m = std::min(d.hi - (r.lo - tol), (r.hi + tol) - d.lo);
      (*margins)[size_t(y) * W + x] = std::min(std::abs(m), box_margin);
      if (m >= 0) out.push_back({x, y, a, b});
    }
  std::sort(out.begin(), out.end(), [](const Visit& p, const Visit& q) { return p.ta < q.ta || (p.ta == q.ta && p.tb < q.tb); });
  return out;
}

DepthImageSegment random_segment(int W, int H, Rng& rng) {
  DepthImageSegment s;
  auto pt = [&] { return Vec2f{(rng.next_float() * 1.4f - 0.2f) * W, (rng.next_float() * 1.4f - 0.2f) * H}; };
  s.p0 = pt();
  s.p1 = pt();
  if (rng.next_float() < 0.1f) s.p1 = {s.p0.x, s.p1.y};  // vertical
  if (rng.next_float() < 0.1f) s.p1 = {s.p1.x, s.p0.y};  // horizontal
  if (rng.next_float() < 0.05f) s.p1 = s.p0;              // a point (a ray along the view axis)
  s.d0 = rng.next_float();
  s.d1 = rng.next_float();
  if (rng.next_float() < 0.5f) {  // grazing the surface: many texels overlap
    s.d0 = 0.35f + 0.3f * rng.next_float();
    s.d1 = s.d0 + 0.1f * (rng.next_float() - 0.5f);
  }
  s.t0 = rng.next_float() < 0.5f ? 0.0f : 0.3f * rng.next_float();
  s.t1 = rng.next_float() < 0.5f ? 1.0f : 1.0f - 0.3f * rng.next_float();
  return s;
}

TEST(DepthImageWalk, VisitsExactlyTheTexelsOfABruteForceMarchFrontToBack) {
  Rng rng(11);
  int compared = 0, marginal_mismatches = 0, visits = 0;
  for (auto size : {std::pair{64, 64}, std::pair{37, 23}, std::pair{1, 1}, std::pair{5, 1}, std::pair{100, 70}}) {
    const int W = size.first, H = size.second;  // plain locals: lambdas below capture them
    std::vector<DepthRange> texels = random_texels(W, H, rng);
    MinMaxPyramid pyr(W, H, texels);
    for (int i = 0; i < 300; ++i) {
      DepthImageSegment seg = random_segment(W, H, rng);
      for (bool clipping : {true, false}) {
        DepthWalkOptions opt;
        opt.minmax_clipping = clipping;
        opt.tolerance = i % 3 == 0 ? 0.0f : 0.05f * rng.next_float();
        std::vector<float> margins;
        std::vector<Visit> want = brute_force(W, H, texels, seg, opt.tolerance, &margins);
        std::vector<Visit> got;
        DepthWalkCounters c;
        bool stopped = walk_depth_image(
            pyr, seg, opt,
            [&](const DepthWalkTexel& t) {
              got.push_back({t.x, t.y, t.t_enter, t.t_exit});
              EXPECT_FLOAT_EQ(t.d_enter, seg.depth_at(t.t_enter));
              EXPECT_EQ(t.range.lo, texels[size_t(t.y) * W + t.x].lo);
              return WalkStep::Continue;
            },
            DescendEveryNode{}, &c);
        EXPECT_FALSE(stopped);
        EXPECT_EQ(c.texels, got.size());
        ++compared;
        visits += int(got.size());
        // Front to back.
        for (size_t k = 1; k < got.size(); ++k) EXPECT_LE(got[k - 1].ta, got[k].ta + 1e-6f);
        // Same set, except texels within rounding of the decision.
        auto key = [&](const Visit& v) { return size_t(v.y) * W + v.x; };
        std::vector<char> in_want(texels.size(), 0), in_got(texels.size(), 0);
        for (const Visit& v : want) in_want[key(v)] = 1;
        for (const Visit& v : got) {
          EXPECT_EQ(in_got[key(v)], 0) << "texel visited twice";
          in_got[key(v)] = 1;
        }
        for (size_t k = 0; k < texels.size(); ++k)
          if (in_want[k] != in_got[k]) {
            ASSERT_LT(margins[k], 1e-4f) << "texel " << k % W << "," << k / W << " want " << int(in_want[k]) << " W " << W
                                         << " clipping " << clipping << " seg " << seg.p0.x << "," << seg.p0.y << " -> " << seg.p1.x << "," << seg.p1.y
                                         << " d " << seg.d0 << "," << seg.d1 << " t " << seg.t0 << "," << seg.t1 << " tol " << opt.tolerance
                                         << " range " << texels[k].lo << "," << texels[k].hi;
            ++marginal_mismatches;
          }
        for (const Visit& v : got)
          if (in_want[key(v)]) {
            auto it = std::find_if(want.begin(), want.end(), [&](const Visit& w) { return key(w) == key(v); });
            EXPECT_NEAR(it->ta, v.ta, 1e-5f);
            EXPECT_NEAR(it->tb, v.tb, 1e-5f);
          }
      }
    }
  }
  EXPECT_GT(visits, 3000);  // the test exercised something
  EXPECT_LT(marginal_mismatches, compared / 50);
}

// The packet walk gives every ray exactly the texels, crossings and depths the single-ray
// walk gives it (bit for bit), for packets of rays from one point (the shadow rays of one
// receiver) and of unrelated rays, with and without min/max clipping, and a ray stopped by
// its leaf visitor gets no further texels while the others go on; on every SIMD target this
// build has and the CPU runs (the node step is dispatched at run time).
void expect_packets_match_single_rays() {
  Rng rng(29);
  struct Leaf {
    int x, y;
    float ta, tb, da, db, ca, cb;
    bool operator<(const Leaf& o) const { return std::tie(y, x) < std::tie(o.y, o.x); }
    bool operator==(const Leaf& o) const {
      return x == o.x && y == o.y && ta == o.ta && tb == o.tb && da == o.da && db == o.db && ca == o.ca && cb == o.cb;
    }
  };
  auto leaf_of = [](const DepthWalkTexel& t) {
    return Leaf{t.x, t.y, t.t_enter, t.t_exit, t.d_enter, t.d_exit, t.t_clip_enter, t.t_clip_exit};
  };
  int rays = 0, texels_seen = 0, stopped_rays = 0;
  for (auto [W, H] : {std::pair{64, 64}, std::pair{37, 23}, std::pair{1, 1}, std::pair{100, 70}}) {
    std::vector<DepthRange> texels = random_texels(W, H, rng);
    MinMaxPyramid pyr(W, H, texels);
    for (int p = 0; p < 60; ++p) {
      const int n = 1 + static_cast<int>(rng.next_float() * kDepthWalkPacket) % kDepthWalkPacket;
      const bool fan = p % 2 == 0;  // rays from one point
      std::vector<DepthImageSegment> segs;
      for (int i = 0; i < n; ++i) {
        DepthImageSegment s = random_segment(W, H, rng);
        if (fan && i > 0) {
          s.p0 = segs[0].p0;
          s.d0 = segs[0].d0;
          s.t0 = segs[0].t0;
        }
        segs.push_back(s);
      }
      for (bool clipping : {true, false}) {
        DepthWalkOptions opt;
        opt.minmax_clipping = clipping;
        opt.tolerance = p % 3 == 0 ? 0.0f : 0.05f * rng.next_float();
        const int stop_after = p % 4 == 1 ? 2 : 1 << 30;  // rays stop at their 2nd texel
        std::vector<std::vector<Leaf>> want(n), got(n);
        DepthWalkCounters single, packet;
        for (int i = 0; i < n; ++i)
          walk_depth_image(
              pyr, segs[i], opt,
              [&](const DepthWalkTexel& t) {
                want[i].push_back(leaf_of(t));
                return int(want[i].size()) >= stop_after ? WalkStep::Stop : WalkStep::Continue;
              },
              DescendEveryNode{}, &single);
        walk_depth_image_packet(
            pyr, segs, opt,
            [&](int i, const DepthWalkTexel& t) {
              EXPECT_GE(i, 0);
              EXPECT_LT(i, n);
              got[i].push_back(leaf_of(t));
              return int(got[i].size()) >= stop_after ? WalkStep::Stop : WalkStep::Continue;
            },
            &packet);
        for (int i = 0; i < n; ++i) {
          ++rays;
          texels_seen += int(want[i].size());
          if (stop_after < (1 << 30)) {
            // Stopped rays: as many texels; which ones depends on the order.
            stopped_rays += int(want[i].size()) == stop_after;
            EXPECT_EQ(got[i].size(), want[i].size()) << "ray " << i;
            continue;
          }
          std::sort(want[i].begin(), want[i].end());
          std::sort(got[i].begin(), got[i].end());
          EXPECT_TRUE(want[i] == got[i]) << "ray " << i << " of " << n << ", " << W << "x" << H << ", clipping "
                                          << clipping << ": " << want[i].size() << " vs " << got[i].size() << " texels";
        }
        if (stop_after == (1 << 30)) EXPECT_EQ(packet.texels, single.texels);
      }
    }
  }
  EXPECT_GT(texels_seen, 3000);  // the test exercised something
  EXPECT_GT(stopped_rays, 20);
}

TEST(DepthImageWalk, PacketsGiveEachRayTheSingleRayWalksTexels) {
  std::set<size_t> dispatched;
  const std::vector<int64_t> targets = hwy::SupportedAndGeneratedTargets();
  for (int64_t target : targets) {
    SCOPED_TRACE(hwy::TargetName(target));
    hwy::SetSupportedTargetsForTest(target);
    hwy::GetChosenTarget().Update(hwy::SupportedTargets());
    dispatched.insert(hwy::GetChosenTarget().GetIndex());
    expect_packets_match_single_rays();
  }
  hwy::SetSupportedTargetsForTest(0);
  hwy::GetChosenTarget().Update(hwy::SupportedTargets());
  EXPECT_EQ(dispatched.size(), targets.size());  // each target was the one dispatched to
}

TEST(DepthImageWalk, MinMaxClippingVisitsFewerNodesForTheSameTexels) {
  Rng rng(3);
  const int W = 128, H = 128;
  std::vector<DepthRange> texels = random_texels(W, H, rng);
  MinMaxPyramid pyr(W, H, texels);
  DepthWalkCounters with, without;
  for (int i = 0; i < 500; ++i) {
    DepthImageSegment seg = random_segment(W, H, rng);
    std::vector<std::pair<int, int>> a, b;
    DepthWalkOptions on, off;
    off.minmax_clipping = false;
    walk_depth_image(pyr, seg, on, [&](const DepthWalkTexel& t) { a.push_back({t.x, t.y}); return WalkStep::Continue; }, DescendEveryNode{}, &with);
    walk_depth_image(pyr, seg, off, [&](const DepthWalkTexel& t) { b.push_back({t.x, t.y}); return WalkStep::Continue; }, DescendEveryNode{}, &without);
    // Clipping may only drop texels the leaf test would reject anyway (up to rounding).
    int diff = 0;
    for (auto& p : b) diff += std::find(a.begin(), a.end(), p) == a.end();
    EXPECT_LE(diff, 1);
  }
  EXPECT_EQ(with.texels <= without.texels, true);
  EXPECT_LT(with.nodes, without.nodes);
}

TEST(DepthImageWalk, LeafAndNodeVisitorsStopAndPrune) {
  Rng rng(5);
  const int W = 64, H = 64;
  std::vector<DepthRange> texels(W * H, DepthRange{0.5f, 0.5f});
  MinMaxPyramid pyr(W, H, texels);
  DepthImageSegment seg;
  seg.p0 = {0.0f, 10.5f};
  seg.p1 = {64.0f, 10.5f};
  const float k = 0.2f / 64;
  seg.d0 = 0.5f - 32.5f * k;
  seg.d1 = 0.5f + 31.5f * k;  // at depth 0.5 at x = 32.5: only texel 32 overlaps
  std::vector<int> xs;
  walk_depth_image(pyr, seg, {}, [&](const DepthWalkTexel& t) { xs.push_back(t.x); return WalkStep::Continue; });
  ASSERT_EQ(xs.size(), 1u);
  EXPECT_EQ(xs[0], 32);
  // A flat ray at the surface's depth reaches every texel on its row, in order; stop at the 5th.
  seg.d0 = seg.d1 = 0.5f;
  xs.clear();
  bool stopped = walk_depth_image(pyr, seg, {}, [&](const DepthWalkTexel& t) {
    xs.push_back(t.x);
    return xs.size() == 5 ? WalkStep::Stop : WalkStep::Continue;
  });
  EXPECT_TRUE(stopped);
  EXPECT_EQ(xs, (std::vector<int>{0, 1, 2, 3, 4}));
  // Skipping every level-3 node (8x8 texels) with x >= 4 leaves the first 32 texels.
  xs.clear();
  int nodes_seen = 0;
  stopped = walk_depth_image(
      pyr, seg, {}, [&](const DepthWalkTexel& t) { xs.push_back(t.x); return WalkStep::Continue; },
      [&](const DepthWalkNode& n) {
        ++nodes_seen;
        EXPECT_GE(n.ray.hi, n.range.lo);
        return n.level == 3 && n.x >= 4 ? NodeStep::Skip : NodeStep::Descend;
      });
  EXPECT_FALSE(stopped);
  ASSERT_EQ(xs.size(), 32u);
  EXPECT_EQ(xs.back(), 31);
  EXPECT_GT(nodes_seen, 6);
  // Stopping at the root visits no texel.
  xs.clear();
  stopped = walk_depth_image(
      pyr, seg, {}, [&](const DepthWalkTexel& t) { xs.push_back(t.x); return WalkStep::Continue; },
      [](const DepthWalkNode&) { return NodeStep::Stop; });
  EXPECT_TRUE(stopped);
  EXPECT_TRUE(xs.empty());
  // Tolerance widens ranges: a ray 0.01 in front of the surface reaches texels only with it.
  seg.d0 = seg.d1 = 0.49f;
  int n0 = 0, n1 = 0;
  walk_depth_image(pyr, seg, {}, [&](const DepthWalkTexel&) { ++n0; return WalkStep::Continue; });
  DepthWalkOptions tol;
  tol.tolerance = 0.011f;
  walk_depth_image(pyr, seg, tol, [&](const DepthWalkTexel&) { ++n1; return WalkStep::Continue; });
  EXPECT_EQ(n0, 0);
  EXPECT_EQ(n1, 64);
}

TEST(DepthImageWalk, SkippedSpansAndTexelsTileTheSegmentInOrder) {
  Rng rng(21);
  int behind = 0, in_front = 0, checked = 0;
  for (auto size : {std::pair{64, 64}, std::pair{37, 23}}) {
    const int W = size.first, H = size.second;  // plain locals: lambdas below capture them
    std::vector<DepthRange> texels = random_texels(W, H, rng);
    MinMaxPyramid pyr(W, H, texels);
    for (int i = 0; i < 400; ++i) {
      DepthImageSegment seg = random_segment(W, H, rng);
      if (seg.p0.x == seg.p1.x && seg.p0.y == seg.p1.y) continue;
      for (bool clipping : {true, false}) {
        DepthWalkOptions opt;
        opt.minmax_clipping = clipping;
        opt.tolerance = 0.01f * rng.next_float();
        std::vector<std::pair<float, float>> spans;
        std::vector<int> leaf_count_before;
        walk_depth_image_with_skips(
            pyr, seg, opt,
            [&](const DepthWalkTexel& t) {
              EXPECT_GE(t.t_clip_enter, t.t_enter - 1e-5f);
              EXPECT_LE(t.t_clip_exit, t.t_exit + 1e-5f);
              spans.push_back({t.t_clip_enter, t.t_clip_exit});
              return WalkStep::Continue;
            },
            DescendEveryNode{},
            [&](const DepthWalkSkip& s) {
              spans.push_back({s.t_enter, s.t_exit});
              if (s.reason != SkipReason::Behind && s.reason != SkipReason::InFront) return;
              // At the span's middle the ray is on the reported side of the texel there.
              float tm = 0.5f * (s.t_enter + s.t_exit);
              Vec2f p = seg.at(tm);
              int x = std::clamp(int(p.x), 0, W - 1), y = std::clamp(int(p.y), 0, H - 1);
              const DepthRange& r = texels[size_t(y) * W + x];
              float fx = p.x - std::floor(p.x), fy = p.y - std::floor(p.y);
              if (r.empty() || fx < 1e-3f || fx > 1 - 1e-3f || fy < 1e-3f || fy > 1 - 1e-3f) return;
              ++checked;
              if (s.reason == SkipReason::Behind) {
                ++behind;
                EXPECT_GT(seg.depth_at(tm), r.hi + opt.tolerance - 1e-5f);
              } else {
                ++in_front;
                EXPECT_LT(seg.depth_at(tm), r.lo - opt.tolerance + 1e-5f);
              }
            });
        ASSERT_FALSE(spans.empty());
        EXPECT_NEAR(spans.front().first, seg.t0, 1e-5f);
        EXPECT_NEAR(spans.back().second, seg.t1, 1e-5f);
        for (size_t k = 1; k < spans.size(); ++k) {
          // Contiguous, except zero-length touches of texel corners and edges.
          if (spans[k].second - spans[k].first < 1e-5f) continue;
          float prev_end = spans[k - 1].second;
          for (size_t j = k - 1; j > 0 && spans[j].second - spans[j].first < 1e-5f; --j) prev_end = std::max(prev_end, spans[j - 1].second);
          EXPECT_NEAR(spans[k].first, prev_end, 1e-4f) << "span " << k << " of " << spans.size();
        }
      }
    }
  }
  EXPECT_GT(behind, 100);
  EXPECT_GT(in_front, 100);
  EXPECT_GT(checked, 300);
}

TEST(DepthImageWalk, ProjectedSegmentsMatchTheViewAndClipAtNear) {
  Rng rng(9);
  LightView persp = LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 60, 200, 150, 0.5f, 20);
  LightView ortho = LightView::orthographic({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, -3, 3, -2, 2, 0.5f, 20, 120, 80);
  for (const LightView* view : {&persp, &ortho}) {
    int clipped = 0;
    for (int i = 0; i < 200; ++i) {
      auto pt = [&] { return Vec3f{6 * rng.next_float() - 3, 6 * rng.next_float() - 3, -12 * rng.next_float() + 0.3f}; };
      Vec3f a = pt(), b = pt();
      ProjectedSegment ps;
      if (!project_to_depth_image(*view, a, b, &ps)) {
        EXPECT_TRUE(view->linear_depth(a) < view->near() && view->linear_depth(b) < view->near());
        continue;
      }
      if (ps.s0 > 0 || ps.s1 < 1) ++clipped;
      EXPECT_GE(ps.z0, view->near());
      for (float t : {0.0f, 0.25f, 0.7f, 1.0f}) {
        float s = ps.world_param(t);
        Vec3f w = a + (b - a) * s;
        Vec3f tex = view->to_texel(w);
        Vec2f p = ps.segment.at(t);
        EXPECT_NEAR(p.x, tex.x, 2e-3f * (1 + std::abs(tex.x)));
        EXPECT_NEAR(p.y, tex.y, 2e-3f * (1 + std::abs(tex.y)));
        EXPECT_NEAR(ps.linear_depth_at(t), tex.z, 1e-4f * (1 + tex.z));
        // Window depth is affine along the texel-space segment.
        EXPECT_NEAR(ps.segment.depth_at(t), view->window_depth(tex.z), 2e-5f);
        EXPECT_NEAR(ps.segment_param(s), t, 1e-4f);
      }
    }
    if (view->is_perspective()) {
      EXPECT_GT(clipped, 10);
    }
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
