#include "penumbra/raster/conservative.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <utility>
#include <vector>

#include "penumbra/core/rng.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

struct P {
  double x, y;
};

// Area of a convex polygon clipped to the box [x0, x1] x [y0, y1] (Sutherland-Hodgman): an
// independent, exact-enough overlap test.
double clipped_area(std::vector<P> poly, double x0, double y0, double x1, double y1) {
  auto clip = [&](auto inside, auto intersect) {
    std::vector<P> out;
    for (size_t i = 0; i < poly.size(); ++i) {
      P a = poly[i], b = poly[(i + 1) % poly.size()];
      bool ia = inside(a), ib = inside(b);
      if (ia) out.push_back(a);
      if (ia != ib) out.push_back(intersect(a, b));
    }
    poly = out;
  };
  auto lerp_x = [](P a, P b, double x) { double s = (x - a.x) / (b.x - a.x); return P{x, a.y + s * (b.y - a.y)}; };
  auto lerp_y = [](P a, P b, double y) { double s = (y - a.y) / (b.y - a.y); return P{a.x + s * (b.x - a.x), y}; };
  clip([&](P p) { return p.x >= x0; }, [&](P a, P b) { return lerp_x(a, b, x0); });
  clip([&](P p) { return p.x <= x1; }, [&](P a, P b) { return lerp_x(a, b, x1); });
  clip([&](P p) { return p.y >= y0; }, [&](P a, P b) { return lerp_y(a, b, y0); });
  clip([&](P p) { return p.y <= y1; }, [&](P a, P b) { return lerp_y(a, b, y1); });
  double area = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    P a = poly[i], b = poly[(i + 1) % poly.size()];
    area += a.x * b.y - a.y * b.x;
  }
  return std::abs(area) * 0.5;
}

// Convex hull (Andrew's monotone chain), counter-clockwise in a y-up sense.
std::vector<Vec2f> convex_hull(std::vector<Vec2f> pts) {
  std::sort(pts.begin(), pts.end(), [](Vec2f a, Vec2f b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  std::vector<Vec2f> h(2 * pts.size());
  size_t k = 0;
  for (size_t i = 0; i < pts.size(); ++i) {
    while (k >= 2 && cross(h[k - 1] - h[k - 2], pts[i] - h[k - 2]) <= 0) --k;
    h[k++] = pts[i];
  }
  for (size_t i = pts.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(h[k - 1] - h[k - 2], pts[i - 1] - h[k - 2]) <= 0) --k;
    h[k++] = pts[i - 1];
  }
  h.resize(k - 1);
  return h;
}

// Coverage collected per texel without locks, relying on the documented contract: all calls
// for one texel come from one thread, in polygon order.
struct Coverage {
  int width, height;
  std::vector<std::vector<uint32_t>> texels;
  Coverage(int w, int h) : width(w), height(h), texels(size_t(w) * h) {}
  CoverageCallback callback() {
    return [this](int x, int y, uint32_t index) {
      EXPECT_TRUE(x >= 0 && x < width && y >= 0 && y < height);
      texels[size_t(y) * width + x].push_back(index);
    };
  }
  std::set<std::pair<int, int>> of(uint32_t index) const {
    std::set<std::pair<int, int>> s;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        for (uint32_t i : texels[size_t(y) * width + x])
          if (i == index) s.insert({x, y});
    return s;
  }
};

TEST(Conservative, CoversExactlyTheTexelsRandomPolygonsTouch) {
  const int W = 48, H = 40;
  Rng rng(101);
  ConvexPolygons polys;
  std::vector<std::vector<P>> exact;
  for (int i = 0; i < 400; ++i) {
    Vec2f c{-6 + (W + 12) * rng.next_float(), -6 + (H + 12) * rng.next_float()};
    float radius = i % 4 == 0 ? 0.6f * rng.next_float() : 0.3f + 8 * rng.next_float();
    std::vector<Vec2f> pts;
    int n = i % 3 == 0 ? 3 : 3 + int(rng.uniform_int(10));
    for (int k = 0; k < n; ++k) pts.push_back(c + Vec2f(rng.next_float() - 0.5f, rng.next_float() - 0.5f) * (2 * radius));
    std::vector<Vec2f> poly = i % 3 == 0 ? pts : convex_hull(pts);  // raw triangles: either winding
    if (i % 2 == 0) std::reverse(poly.begin(), poly.end());
    polys.add(poly);
    std::vector<P> e;
    for (Vec2f v : poly) e.push_back({v.x, v.y});
    exact.push_back(e);
  }
  Coverage cov(W, H);
  ConservativeRasterizer(16).polygons(polys, W, H, cov.callback());
  for (const auto& list : cov.texels)
    for (size_t k = 1; k < list.size(); ++k) ASSERT_LT(list[k - 1], list[k]);  // once each, in order
  int overlapping = 0, touching_only = 0;
  for (uint32_t i = 0; i < polys.size(); ++i) {
    std::set<std::pair<int, int>> got = cov.of(i);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        bool overlaps = clipped_area(exact[i], x, y, x + 1, y + 1) > 1e-9;
        bool covered = got.count({x, y}) > 0;
        if (overlaps) {
          ++overlapping;
          EXPECT_TRUE(covered) << "polygon " << i << " misses texel " << x << "," << y;
        }
        if (covered && !overlaps) {
          ++touching_only;
          // Reported without overlapping: it must touch the polygon (within the 1e-5 texel
          // tolerance), far closer than sintorn2008's one-texel slack.
          EXPECT_GT(clipped_area(exact[i], x - 1e-4, y - 1e-4, x + 1 + 1e-4, y + 1 + 1e-4), 0)
              << "polygon " << i << " reports far texel " << x << "," << y;
          EXPECT_GT(clipped_area(exact[i], x - 1, y - 1, x + 2, y + 2), 0);
        }
      }
  }
  EXPECT_GT(overlapping, 5000);
  EXPECT_LT(touching_only, overlapping / 100);
  // The span form reports the same texels, each once, in the same order per texel.
  Coverage spans(W, H);
  ConservativeRasterizer(16).polygon_spans(polys, W, H, [&](int y, int x0, int x1, uint32_t index) {
    ASSERT_LT(x0, x1);
    for (int x = x0; x < x1; ++x) spans.callback()(x, y, index);
  });
  EXPECT_EQ(spans.texels, cov.texels);
}

TEST(Conservative, DegeneratePolygonsCoverWhatTheyTouch) {
  const int W = 16, H = 16;
  ConvexPolygons polys;
  std::vector<Vec2f> point = {{4.5f, 6.5f}};
  std::vector<Vec2f> corner = {{3, 3}, {3, 3}, {3, 3}};
  std::vector<Vec2f> segment = {{2.25f, 3.75f}, {9.5f, 3.75f}};  // horizontal, inside row 3
  polys.add(point);
  polys.add(corner);
  polys.add(segment);
  Coverage cov(W, H);
  ConservativeRasterizer().polygons(polys, W, H, cov.callback());
  EXPECT_EQ(cov.of(0), (std::set<std::pair<int, int>>{{4, 6}}));
  EXPECT_EQ(cov.of(1), (std::set<std::pair<int, int>>{{2, 2}, {3, 2}, {2, 3}, {3, 3}}));
  std::set<std::pair<int, int>> row;
  for (int x = 2; x <= 9; ++x) row.insert({x, 3});
  EXPECT_EQ(cov.of(2), row);
}

TEST(Conservative, TrianglesCoverTheirProjectionAndEveryRasterizedTexel) {
  const int W = 64, H = 48;
  LightView view = LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 60, W, H, 1, 12);
  Rng rng(77);
  std::vector<RasterTriangle> tris;
  ConvexPolygons projected;
  for (int i = 0; i < 150; ++i) {
    float z = -2 - 6 * rng.next_float();
    Vec3f c{(rng.next_float() - 0.5f) * 1.3f * -z, (rng.next_float() - 0.5f) * -z, z};
    RasterTriangle t;
    std::vector<Vec2f> poly;
    for (Vec3f& p : t.p) {
      p = c + Vec3f(rng.next_float() - 0.5f, rng.next_float() - 0.5f, 0.6f * (rng.next_float() - 0.5f)) *
                  (i % 5 == 0 ? 0.05f : 1.5f);
      Vec3f q = view.to_texel(p);
      poly.push_back({q.x, q.y});
    }
    tris.push_back(t);
    projected.add(poly);
  }
  Coverage from_triangles(W, H), from_polygons(W, H);
  ConservativeRasterizer cr(16);
  cr.triangles(tris, view, {}, from_triangles.callback());
  cr.polygons(projected, W, H, from_polygons.callback());
  FragmentLists lists = render_fragment_lists(tris, view);
  size_t differ = 0, missed = 0, total = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const auto& a = from_triangles.texels[size_t(y) * W + x];
      const auto& b = from_polygons.texels[size_t(y) * W + x];
      if (a != b) ++differ;
      total += a.size();
      for (const Fragment& f : lists.at(x, y))
        if (std::find(a.begin(), a.end(), f.triangle) == a.end()) ++missed;
    }
  // The two paths project vertices with different float roundings; a texel only touched at
  // the 1e-5 tolerance may differ, nothing more.
  EXPECT_LE(differ, 2u);
  EXPECT_EQ(missed, 0u);  // conservative coverage contains standard coverage
  EXPECT_GT(total, lists.total());
}

TEST(Conservative, TrianglesAreClippedAtTheNearPlane) {
  LightView view = LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 90, 32, 32, 1, 10);
  // Entirely between the eye and the near plane: nothing. Crossing it: only texels whose
  // rays meet the part beyond near, which here lies in the right half of the image.
  RasterTriangle before, crossing;
  before.p[0] = {-0.2f, -0.2f, -0.5f}; before.p[1] = {0.2f, -0.2f, -0.5f}; before.p[2] = {0, 0.2f, -0.5f};
  crossing.p[0] = {0.1f, -0.5f, -0.5f}; crossing.p[1] = {3, -0.5f, -3}; crossing.p[2] = {0.1f, 0.5f, -0.5f};
  Coverage cov(32, 32);
  ConservativeRasterizer().triangles(std::vector<RasterTriangle>{before, crossing}, view, {}, cov.callback());
  EXPECT_TRUE(cov.of(0).empty());
  std::set<std::pair<int, int>> got = cov.of(1);
  EXPECT_FALSE(got.empty());
  // Beyond the near plane the triangle spans x / depth in [0.68, 1], texel x = 16 (1 + x / depth)
  // in [26.88, 32]; the clipped-away part (x / depth down to 0.2) would reach texel 19.
  for (auto [x, y] : got) EXPECT_GE(x, 26) << y;
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
