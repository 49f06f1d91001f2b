#include "penumbra/raster/rasterizer.h"

#include <gtest/gtest.h>

#include <embree3/rtcore.h>

#include <algorithm>
#include <bit>
#include <filesystem>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/raster/test_meshes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// An orthographic view looking down -z with one texel per world unit: world (x, y, *) lands
// on texel-space point (x, H - y), so texel centres are at half-integer world coordinates and
// edges can be placed exactly through them.
LightView unit_ortho(int w, int h) {
  return LightView::orthographic({0, 0, 10}, {0, 0, -1}, {0, 1, 0}, 0, float(w), 0, float(h), 1, 20, w, h);
}

RasterTriangle tri(Vec3f a, Vec3f b, Vec3f c, float opacity = 1, uint32_t prim = 0) {
  RasterTriangle t;
  t.p[0] = a; t.p[1] = b; t.p[2] = c;
  t.opacity = opacity;
  t.prim = prim;
  return t;
}

// ---------------------------------------------------------------------------------------
// Ground truth by brute force: every triangle against the ray through every texel centre,
// in double precision. A texel is ambiguous when its centre lies within kEdgeTolerance
// texels of a projected triangle edge: the rasterizer snaps vertices to 1/256 texel (edges
// move by at most sqrt(2)/512 texel), so coverage of such centres may legitimately differ.

constexpr double kEdgeTolerance = 0.01;

struct BruteFragment {
  double z;
  float opacity;
  uint32_t triangle;
};

struct BruteForce {
  int width = 0, height = 0;
  std::vector<std::vector<BruteFragment>> lists;  // per texel, sorted by (z, triangle)
  std::vector<bool> ambiguous;
};

double edge_distance(double px, double py, double ax, double ay, double bx, double by) {
  double dx = bx - ax, dy = by - ay, len2 = dx * dx + dy * dy;
  double s = len2 > 0 ? std::clamp(((px - ax) * dx + (py - ay) * dy) / len2, 0.0, 1.0) : 0.0;
  double ex = ax + s * dx - px, ey = ay + s * dy - py;
  return std::sqrt(ex * ex + ey * ey);
}

// All triangles must lie in front of the near plane (their projection is then a triangle).
BruteForce brute_force(const std::vector<RasterTriangle>& tris, const LightView& view) {
  BruteForce bf;
  bf.width = view.width();
  bf.height = view.height();
  size_t n = static_cast<size_t>(bf.width) * bf.height;
  bf.lists.resize(n);
  bf.ambiguous.assign(n, false);
  for (uint32_t ti = 0; ti < tris.size(); ++ti) {
    const RasterTriangle& t = tris[ti];
    double tx[3], ty[3];
    for (int k = 0; k < 3; ++k) {
      Vec3f q = view.to_texel(t.p[k]);
      tx[k] = q.x;
      ty[k] = q.y;
    }
    double area = (tx[1] - tx[0]) * (ty[2] - ty[0]) - (ty[1] - ty[0]) * (tx[2] - tx[0]);
    int x0 = std::max(0, int(std::floor(std::min({tx[0], tx[1], tx[2]}))) - 1);
    int x1 = std::min(bf.width - 1, int(std::ceil(std::max({tx[0], tx[1], tx[2]}))) + 1);
    int y0 = std::max(0, int(std::floor(std::min({ty[0], ty[1], ty[2]}))) - 1);
    int y1 = std::min(bf.height - 1, int(std::ceil(std::max({ty[0], ty[1], ty[2]}))) + 1);
    Vec3f e1 = t.p[1] - t.p[0], e2 = t.p[2] - t.p[0];
    double nx = double(e1.y) * e2.z - double(e1.z) * e2.y;
    double ny = double(e1.z) * e2.x - double(e1.x) * e2.z;
    double nz = double(e1.x) * e2.y - double(e1.y) * e2.x;
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        double px = x + 0.5, py = y + 0.5;
        size_t i = static_cast<size_t>(y) * bf.width + x;
        bool inside = area != 0;
        for (int k = 0; k < 3; ++k) {
          int j = (k + 1) % 3;
          if (edge_distance(px, py, tx[k], ty[k], tx[j], ty[j]) < kEdgeTolerance) bf.ambiguous[i] = true;
          double e = (tx[j] - tx[k]) * (py - ty[k]) - (ty[j] - ty[k]) * (px - tx[k]);
          if (e * area < 0) inside = false;
        }
        if (!inside) continue;
        // Ray-plane intersection: origin + z dir has linear depth z.
        LightView::TexelRay r = view.texel_ray({float(px), float(py)});
        double ox = double(r.origin.x) - t.p[0].x, oy = double(r.origin.y) - t.p[0].y, oz = double(r.origin.z) - t.p[0].z;
        double z = -(nx * ox + ny * oy + nz * oz) / (nx * r.dir.x + ny * r.dir.y + nz * r.dir.z);
        if (z < view.near() || z > view.far()) continue;
        bf.lists[i].push_back({z, t.opacity, ti});
      }
  }
  for (auto& l : bf.lists)
    std::sort(l.begin(), l.end(), [](const BruteFragment& a, const BruteFragment& b) {
      return a.z < b.z || (a.z == b.z && a.triangle < b.triangle);
    });
  return bf;
}

// Random triangles in front of a 64 x 48 perspective view, overlapping a lot (depth
// complexity around 6), with random opacities (a third semi-transparent).
std::vector<RasterTriangle> random_triangles(int count, uint64_t seed) {
  Rng rng(seed);
  std::vector<RasterTriangle> tris;
  for (int i = 0; i < count; ++i) {
    float z = -2.5f - 5 * rng.next_float();
    Vec3f c{(rng.next_float() - 0.5f) * 1.2f * -z, (rng.next_float() - 0.5f) * 0.9f * -z, z};
    auto jitter = [&] {
      return c + Vec3f(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f) * 3.0f;
    };
    float opacity = rng.next_float() < 0.33f ? 0.2f + 0.6f * rng.next_float() : 1.0f;
    tris.push_back(tri(jitter(), jitter(), jitter(), opacity, uint32_t(i)));
  }
  return tris;
}

LightView random_scene_view() {
  return LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 60, 64, 48, 1, 12);
}

// ---------------------------------------------------------------------------------------

TEST(Rasterizer, FillRuleCoversEachCentreOfATriangulatedRectangleOnce) {
  // A 8 x 8 grid of cells, 3 texels each, corners on texel centres, diagonals alternating and
  // windings mixed: every centre on an internal edge or vertex must be covered exactly once;
  // on the rectangle's border the top and left sides are in, the bottom and right sides out.
  const int W = 32, H = 32;
  LightView view = unit_ortho(W, H);
  std::vector<RasterTriangle> tris;
  for (int b = 0; b < 8; ++b)
    for (int a = 0; a < 8; ++a) {
      Vec3f p00{0.5f + 3 * a, 0.5f + 3 * b, 0}, p10 = p00 + Vec3f(3, 0, 0), p01 = p00 + Vec3f(0, 3, 0),
          p11 = p00 + Vec3f(3, 3, 0);
      bool flip = (a + b) % 2 == 1;
      RasterTriangle t1 = flip ? tri(p00, p10, p11) : tri(p00, p10, p01);
      RasterTriangle t2 = flip ? tri(p00, p11, p01) : tri(p10, p11, p01);
      if ((a * 7 + b * 3) % 4 == 0) std::swap(t1.p[1], t1.p[2]);  // clockwise too
      if ((a * 5 + b) % 3 == 0) std::swap(t2.p[0], t2.p[2]);
      tris.push_back(t1);
      tris.push_back(t2);
    }
  FragmentLists lists = render_fragment_lists(tris, view);
  // Texel-space rectangle: x in [0.5, 24.5], y in [H - 24.5, H - 0.5] = [7.5, 31.5].
  int mismatches = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      double cx = x + 0.5, cy = y + 0.5;
      uint32_t expected = (cx >= 0.5 && cx < 24.5 && cy >= 7.5 && cy < 31.5) ? 1 : 0;
      if (lists.count(x, y) != expected) ++mismatches;
    }
  EXPECT_EQ(mismatches, 0);
}

TEST(Rasterizer, FillRuleSharedDiagonalsOfRandomQuads) {
  // Random convex quads with vertices on texel centres, split along a diagonal: every centre
  // strictly inside the quad (the diagonal included) is covered exactly once, none twice.
  const int W = 24, H = 24;
  LightView view = unit_ortho(W, H);
  Rng rng(11);
  int tested = 0, on_diagonal = 0;
  Rasterizer raster(16);
  FragmentLists lists;
  for (int iter = 0; iter < 300; ++iter) {
    // Four points on texel centres (half-integer world coordinates), in angular order.
    Vec2f q[4];
    for (auto& p : q) p = {0.5f + float(rng.uniform_int(W)), 0.5f + float(rng.uniform_int(H))};
    Vec2f c = (q[0] + q[1] + q[2] + q[3]) * 0.25f;
    std::sort(q, q + 4, [&](Vec2f a, Vec2f b) { return std::atan2(a.y - c.y, a.x - c.x) < std::atan2(b.y - c.y, b.x - c.x); });
    bool convex = true;
    for (int k = 0; k < 4; ++k) {
      Vec2f a = q[k], b = q[(k + 1) % 4], d = q[(k + 2) % 4];
      if (cross(b - a, d - b) <= 0) convex = false;
    }
    if (!convex) continue;
    ++tested;
    auto w = [](Vec2f p) { return Vec3f(p.x, p.y, 0); };
    std::vector<RasterTriangle> tris = {tri(w(q[0]), w(q[1]), w(q[2])), tri(w(q[2]), w(q[3]), w(q[0]))};
    raster.fragment_lists(tris, view, {}, &lists);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        Vec2f p{x + 0.5f, H - (y + 0.5f)};  // the centre in world x, y
        bool strictly_inside = true;
        for (int k = 0; k < 4; ++k)
          if (cross(q[(k + 1) % 4] - q[k], p - q[k]) <= 0) strictly_inside = false;
        uint32_t n = lists.count(x, y);
        ASSERT_LE(n, 1u) << "quad " << iter << " texel " << x << "," << y;
        if (strictly_inside) {
          EXPECT_EQ(n, 1u) << "quad " << iter << " texel " << x << "," << y;
          if (cross(q[2] - q[0], p - q[0]) == 0) ++on_diagonal;
        }
      }
  }
  EXPECT_GT(tested, 50);
  EXPECT_GT(on_diagonal, 50);  // the shared edge really went through centres
}

TEST(Rasterizer, FillRuleFanAroundACentreCoversItOnce) {
  const int W = 16, H = 16;
  LightView view = unit_ortho(W, H);
  Vec3f c{8.5f, 8.5f, 0};
  const Vec3f ring[7] = {{13.5f, 8.5f, 0}, {11.5f, 12.5f, 0}, {8.5f, 14.5f, 0}, {3.5f, 11.5f, 0},
                         {2.5f, 6.5f, 0},  {6.5f, 2.5f, 0},   {12.5f, 3.5f, 0}};
  std::vector<RasterTriangle> tris;
  for (int k = 0; k < 7; ++k) tris.push_back(tri(c, ring[k], ring[(k + 1) % 7]));
  FragmentLists lists = render_fragment_lists(tris, view);
  EXPECT_EQ(lists.count(8, H - 9), 1u);  // world (8.5, 8.5) is texel (8, 7)
  // Every centre strictly inside the fan's outline is covered once.
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      Vec2f p{x + 0.5f, H - (y + 0.5f)};
      bool inside = true;
      for (int k = 0; k < 7; ++k) {
        Vec2f a{ring[k].x, ring[k].y}, b{ring[(k + 1) % 7].x, ring[(k + 1) % 7].y};
        if (cross(b - a, p - a) <= 0) inside = false;
      }
      ASSERT_LE(lists.count(x, y), 1u);
      if (inside) EXPECT_EQ(lists.count(x, y), 1u) << x << "," << y;
    }
}

TEST(Rasterizer, NearPlaneClippingKeepsOnlyThePartInFront) {
  // One triangle from behind the eye, through the near plane, to well in front: only the
  // part at linear depth >= near may be drawn, at the right depth, and nothing may be
  // mirrored from behind the eye.
  const int W = 64, H = 64;
  LightView view = LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 90, W, H, 1, 100);
  RasterTriangle t = tri({-3, -2, -0.2f}, {3, -1, -5}, {0.5f, 3, 0.5f});
  DepthMap map = render_depth_map(std::vector<RasterTriangle>{t}, view);
  Vec3f e1 = t.p[1] - t.p[0], e2 = t.p[2] - t.p[0];
  int covered = 0, clipped = 0, mismatches = 0;
  double max_error = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      LightView::TexelRay r = view.texel_ray({x + 0.5f, y + 0.5f});
      // Moller-Trumbore in double; the ray parameter is the linear depth.
      Vec3f pv = cross(r.dir, e2);
      double det = dot(e1, pv);
      Vec3f tv = r.origin - t.p[0];
      double u = dot(tv, pv) / det;
      Vec3f qv = cross(tv, e1);
      double v = dot(r.dir, qv) / det, z = dot(e2, qv) / det;
      bool hit = u >= 0 && v >= 0 && u + v <= 1 && z > 0;
      bool ambiguous = std::min({std::abs(u), std::abs(v), std::abs(1 - u - v)}) < 1e-3 || std::abs(z - 1) < 1e-3;
      bool expected = hit && z >= 1;
      if (hit && z < 1) ++clipped;
      if (ambiguous) continue;
      if (expected != map.covered(x, y)) ++mismatches;
      if (expected && map.covered(x, y)) {
        ++covered;
        max_error = std::max(max_error, std::abs(map.z[map.index(x, y)] - z) / z);
      }
    }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(covered, 200);
  EXPECT_GT(clipped, 100);  // the near plane really cut the triangle
  EXPECT_LT(max_error, 1e-5);
}

TEST(Rasterizer, TriangleEntirelyBehindTheEyeOrBeyondFarIsDropped) {
  LightView view = LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 90, 32, 32, 1, 10);
  std::vector<RasterTriangle> tris = {tri({-1, -1, 2}, {1, -1, 2}, {0, 1, 2}),          // behind
                                      tri({-1, -1, -20}, {1, -1, -20}, {0, 1, -20})};   // beyond far
  Rasterizer raster;
  DepthMap map;
  raster.depth_map(tris, view, {}, &map);
  EXPECT_EQ(raster.stats().fragments, 0u);
}

// Loads the bunny and builds an Embree scene of the same triangles: the ground truth.
class BunnyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(test_meshes::kBunnyPath)) GTEST_SKIP() << "no " << test_meshes::kBunnyPath;
    tris_ = test_meshes::read_obj(test_meshes::kBunnyPath);
    ASSERT_EQ(tris_.size(), 69666u);
    device_ = rtcNewDevice(nullptr);
    scene_ = rtcNewScene(device_);
    rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), 3 * tris_.size()));
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                3 * sizeof(unsigned), tris_.size()));
    for (size_t i = 0; i < tris_.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        v[9 * i + 3 * k + 0] = tris_[i].p[k].x;
        v[9 * i + 3 * k + 1] = tris_[i].p[k].y;
        v[9 * i + 3 * k + 2] = tris_[i].p[k].z;
        idx[3 * i + k] = static_cast<unsigned>(3 * i + k);
      }
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene_, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene_);
  }
  void TearDown() override {
    if (scene_) rtcReleaseScene(scene_);
    if (device_) rtcReleaseDevice(device_);
  }

  // The depth map must equal a ray cast through every texel centre: same hit/miss mask and
  // the same linear depth, except at centres within kEdgeTolerance texels of a projected
  // edge (vertex snapping to 1/256 texel may flip those; see brute_force above).
  void compare_with_ray_casts(const LightView& view) {
    DepthMap map = render_depth_map(tris_, view);
    const int W = view.width(), H = view.height();
    std::vector<bool> near_edge(static_cast<size_t>(W) * H, false);
    for (const RasterTriangle& t : tris_) {
      double tx[3], ty[3];
      for (int k = 0; k < 3; ++k) {
        Vec3f q = view.to_texel(t.p[k]);
        tx[k] = q.x;
        ty[k] = q.y;
      }
      int x0 = std::max(0, int(std::floor(std::min({tx[0], tx[1], tx[2]}) - 1)));
      int x1 = std::min(W - 1, int(std::ceil(std::max({tx[0], tx[1], tx[2]}) + 1)));
      int y0 = std::max(0, int(std::floor(std::min({ty[0], ty[1], ty[2]}) - 1)));
      int y1 = std::min(H - 1, int(std::ceil(std::max({ty[0], ty[1], ty[2]}) + 1)));
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x)
          for (int k = 0; k < 3; ++k)
            if (edge_distance(x + 0.5, y + 0.5, tx[k], ty[k], tx[(k + 1) % 3], ty[(k + 1) % 3]) < kEdgeTolerance)
              near_edge[static_cast<size_t>(y) * W + x] = true;
    }
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    int hits = 0, misses = 0, skipped = 0, mask_mismatch = 0, depth_mismatch = 0;
    double max_error = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        LightView::TexelRay r = view.texel_ray({x + 0.5f, y + 0.5f});
        RTCRayHit rh{};
        rh.ray.org_x = r.origin.x; rh.ray.org_y = r.origin.y; rh.ray.org_z = r.origin.z;
        rh.ray.dir_x = r.dir.x; rh.ray.dir_y = r.dir.y; rh.ray.dir_z = r.dir.z;
        rh.ray.tnear = view.near();  // origin + t dir has linear depth t
        rh.ray.tfar = view.far();
        rh.ray.mask = ~0u;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene_, &ctx, &rh);
        bool hit = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
        size_t i = static_cast<size_t>(y) * W + x;
        if (near_edge[i]) {
          ++skipped;
          continue;
        }
        hit ? ++hits : ++misses;
        if (hit != map.covered(x, y)) {
          ++mask_mismatch;
          continue;
        }
        if (!hit) continue;
        double err = std::abs(double(map.z[i]) - rh.ray.tfar) / rh.ray.tfar;
        max_error = std::max(max_error, err);
        if (err > 1e-4) ++depth_mismatch;
        EXPECT_FLOAT_EQ(map.depth[i], view.window_depth(map.z[i]));
      }
    RecordProperty("skipped_near_edge", skipped);
    RecordProperty("max_relative_depth_error", std::to_string(max_error));
    EXPECT_EQ(mask_mismatch, 0);
    EXPECT_EQ(depth_mismatch, 0) << "max relative error " << max_error;
    EXPECT_GT(hits, W * H / 10);
    EXPECT_GT(misses, W * H / 10);
    EXPECT_LT(skipped, W * H / 20);  // the tolerance band stays a thin sliver
  }

  std::vector<RasterTriangle> tris_;
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
};

TEST_F(BunnyTest, PerspectiveDepthMapEqualsRayCasts) {
  Bounds3f b = test_meshes::bounds_of(tris_);
  Vec3f eye = b.center() + Vec3f(0.6f, 0.8f, 1.5f) * length(b.diagonal());
  compare_with_ray_casts(LightView::frustum_fitted(eye, b.center() - eye, {0, 1, 0}, b, 384, 320, 0.01f));
}

TEST_F(BunnyTest, OrthographicDepthMapEqualsRayCasts) {
  Bounds3f b = test_meshes::bounds_of(tris_);
  compare_with_ray_casts(LightView::orthographic_fitted({-0.3f, -1, -0.5f}, {0, 1, 0}, b, 256, 256));
}

TEST(Rasterizer, DepthMapIsTheNearestFragment) {
  std::vector<RasterTriangle> tris = random_triangles(80, 5);
  LightView view = random_scene_view();
  BruteForce bf = brute_force(tris, view);
  for (bool opaque_only : {false, true}) {
    RasterFilter filter;
    filter.opaque_only = opaque_only;
    DepthMap map;
    Rasterizer raster(16);
    raster.depth_map(tris, view, filter, &map);
    int checked = 0;
    for (int y = 0; y < view.height(); ++y)
      for (int x = 0; x < view.width(); ++x) {
        size_t i = map.index(x, y);
        if (bf.ambiguous[i]) continue;
        const BruteFragment* nearest = nullptr;
        for (const BruteFragment& f : bf.lists[i])
          if (!opaque_only || f.opacity >= 1) {
            nearest = &f;
            break;
          }
        ASSERT_EQ(map.covered(x, y), nearest != nullptr) << x << "," << y;
        if (!nearest) continue;
        ++checked;
        EXPECT_NEAR(map.z[i], nearest->z, 1e-5 * nearest->z);
        EXPECT_EQ(map.triangle[i], nearest->triangle);
        EXPECT_EQ(map.opacity[i], nearest->opacity);
      }
    EXPECT_GT(checked, 1500);
  }
}

// The reference rule for distinct layers (rasterizer.cpp): sorted fragments grouped greedily
// from the front, a new layer when a fragment lies more than eps behind the current layer's
// front; a layer keeps its front's depth and triangle, opacity 1 - prod(1 - a).
std::vector<DepthSample> brute_layers(const std::vector<BruteFragment>& frags, int k, double eps, bool opaque_only) {
  std::vector<DepthSample> layers;
  double front = 0;  // of the last layer, in double like the fragments
  for (const BruteFragment& f : frags) {
    if (opaque_only && f.opacity < 1) continue;
    if (!layers.empty() && f.z - front <= eps) {
      layers.back().opacity = 1 - (1 - layers.back().opacity) * (1 - f.opacity);
      continue;
    }
    if (static_cast<int>(layers.size()) == k) break;
    layers.push_back({float(f.z), 0, f.opacity, f.triangle});
    front = f.z;
  }
  return layers;
}

void expect_layers_match(const std::vector<RasterTriangle>& tris, const LightView& view, const BruteForce& bf,
                         const LayerOptions& options, double eps_gap_check) {
  LayeredDepthMap map;
  Rasterizer raster(16);
  raster.layered_depth_map(tris, view, options, &map);
  int checked = 0, deep = 0;
  for (int y = 0; y < view.height(); ++y)
    for (int x = 0; x < view.width(); ++x) {
      size_t i = map.index(x, y);
      if (bf.ambiguous[i]) continue;
      // Texels where fragments chain at about epsilon apart are order-dependent by design.
      bool chained = false;
      for (size_t j = 1; j < bf.lists[i].size(); ++j) {
        double gap = bf.lists[i][j].z - bf.lists[i][j - 1].z;
        if (gap > 0.4 * eps_gap_check && gap < 3 * eps_gap_check) chained = true;
      }
      if (chained) continue;
      std::vector<DepthSample> want = brute_layers(bf.lists[i], options.layers, options.distinct_epsilon,
                                                   options.filter.opaque_only);
      std::span<const DepthSample> got = map.layers(x, y);
      ASSERT_EQ(got.size(), want.size()) << x << "," << y;
      ++checked;
      if (int(want.size()) == options.layers) ++deep;
      for (size_t l = 0; l < want.size(); ++l) {
        EXPECT_NEAR(got[l].z, want[l].z, 1e-5 * want[l].z) << x << "," << y << " layer " << l;
        EXPECT_EQ(got[l].triangle, want[l].triangle) << x << "," << y << " layer " << l;
        EXPECT_NEAR(got[l].opacity, want[l].opacity, 1e-6) << x << "," << y << " layer " << l;
        EXPECT_FLOAT_EQ(got[l].depth, view.window_depth(got[l].z));
        if (l > 0) EXPECT_GT(got[l].z, got[l - 1].z + options.distinct_epsilon);
      }
    }
  EXPECT_GT(checked, 1500);
  EXPECT_GT(deep, 100);  // lists really overflowed k
}

TEST(Rasterizer, LayeredDepthEqualsSortedBruteForce) {
  std::vector<RasterTriangle> tris = random_triangles(120, 9);
  LightView view = random_scene_view();
  BruteForce bf = brute_force(tris, view);
  LayerOptions options;
  options.layers = 4;
  expect_layers_match(tris, view, bf, options, 0);
  options.filter.opaque_only = true;
  options.layers = 3;
  expect_layers_match(tris, view, bf, options, 0);
}

TEST(Rasterizer, LayeredDepthMergesCoincidentSurfaces) {
  // Every other triangle has a twin moved 0.2 epsilon farther from the light, and some are
  // duplicated exactly: each pair must become one layer with composed opacity, the nearer
  // one's depth and triangle.
  std::vector<RasterTriangle> base = random_triangles(70, 21);
  const float eps = 2e-3f;
  std::vector<RasterTriangle> tris;
  for (size_t i = 0; i < base.size(); ++i) {
    tris.push_back(base[i]);
    if (i % 2 == 0) {
      RasterTriangle twin = base[i];
      // Scaled about the eye: the same projection, each depth at most 0.2 epsilon farther.
      float zmax = std::max({-twin.p[0].z, -twin.p[1].z, -twin.p[2].z});
      for (Vec3f& p : twin.p) p = p * (1 + 0.2f * eps / zmax);
      twin.opacity = 0.5f;
      tris.push_back(twin);
    } else if (i % 3 == 0) {
      tris.push_back(base[i]);  // exact duplicate
    }
  }
  LightView view = random_scene_view();
  BruteForce bf = brute_force(tris, view);
  LayerOptions options;
  options.layers = 4;
  options.distinct_epsilon = eps;
  expect_layers_match(tris, view, bf, options, eps);
  // With epsilon 0 only exact duplicates merge; the twins stay separate layers.
  options.distinct_epsilon = 0;
  expect_layers_match(tris, view, bf, options, eps);
}

TEST(Rasterizer, FragmentListsEqualBruteForce) {
  std::vector<RasterTriangle> tris = random_triangles(100, 13);
  LightView view = random_scene_view();
  BruteForce bf = brute_force(tris, view);
  Rasterizer raster(16);
  FragmentLists lists;
  raster.fragment_lists(tris, view, {}, &lists);
  ASSERT_EQ(lists.offsets.size(), size_t(view.width()) * view.height() + 1);
  EXPECT_EQ(lists.offsets.back(), lists.fragments.size());
  EXPECT_EQ(lists.total(), raster.stats().fragments);
  int checked = 0, translucent = 0;
  for (int y = 0; y < view.height(); ++y)
    for (int x = 0; x < view.width(); ++x) {
      size_t i = lists.index(x, y);
      if (bf.ambiguous[i]) continue;
      std::span<const Fragment> got = lists.at(x, y);
      ASSERT_EQ(got.size(), bf.lists[i].size()) << x << "," << y;
      ++checked;
      for (size_t k = 0; k < got.size(); ++k) {
        EXPECT_NEAR(got[k].z, bf.lists[i][k].z, 1e-5 * bf.lists[i][k].z);
        EXPECT_EQ(got[k].triangle, bf.lists[i][k].triangle);
        EXPECT_EQ(got[k].opacity, bf.lists[i][k].opacity);
        if (got[k].opacity < 1) ++translucent;
      }
    }
  EXPECT_GT(checked, 1500);
  EXPECT_GT(translucent, 1000);
}

TEST(Rasterizer, FragmentReducerAndVisitorSeeTheSameSortedLists) {
  std::vector<RasterTriangle> tris = random_triangles(100, 17);
  LightView view = random_scene_view();
  Rasterizer raster(16);
  FragmentLists all, reduced;
  raster.fragment_lists(tris, view, {}, &all);
  // Keep the first fragment and a summary of the rest (its opacity = the composed opacity of
  // the others), like a deep-shadow compressor would.
  std::vector<int> calls(size_t(view.width()) * view.height(), 0);
  raster.fragment_lists(tris, view, {}, &reduced, [&](int x, int y, std::span<Fragment> f) -> uint32_t {
    ++calls[size_t(y) * view.width() + x];
    for (size_t k = 1; k < f.size(); ++k) EXPECT_LE(f[k - 1].z, f[k].z);
    if (f.size() <= 1) return static_cast<uint32_t>(f.size());
    float keep = 1;
    for (size_t k = 1; k < f.size(); ++k) keep *= 1 - f[k].opacity;
    f[1] = {f.back().z, 1 - keep, f[1].triangle};
    return 2;
  });
  for (int c : calls) ASSERT_EQ(c, 1);  // once per texel, empty ones included
  std::vector<int> visits(calls.size(), 0);
  size_t mismatches = 0;
  raster.visit_fragments(tris, view, {}, [&](int x, int y, std::span<const Fragment> f) {
    ++visits[size_t(y) * view.width() + x];
    std::span<const Fragment> want = all.at(x, y);
    if (f.size() != want.size()) {
      ++mismatches;
      return;
    }
    for (size_t k = 0; k < f.size(); ++k)
      if (f[k].z != want[k].z || f[k].triangle != want[k].triangle) ++mismatches;
  });
  EXPECT_EQ(mismatches, 0u);
  for (int v : visits) ASSERT_EQ(v, 1);
  size_t multi = 0;
  for (int y = 0; y < view.height(); ++y)
    for (int x = 0; x < view.width(); ++x) {
      std::span<const Fragment> a = all.at(x, y), r = reduced.at(x, y);
      ASSERT_EQ(r.size(), std::min<size_t>(a.size(), 2));
      if (a.size() < 2) continue;
      ++multi;
      float keep = 1;
      for (size_t k = 1; k < a.size(); ++k) keep *= 1 - a[k].opacity;
      EXPECT_EQ(r[0].z, a[0].z);
      EXPECT_EQ(r[1].z, a.back().z);
      EXPECT_NEAR(r[1].opacity, 1 - keep, 1e-6);
    }
  EXPECT_GT(multi, 1000u);
}

TEST(Rasterizer, FaceCullingKeepsTheRequestedSide) {
  // Two triangles facing the light (counter-clockwise seen from it) and one facing away.
  const int W = 16, H = 16;
  LightView view = unit_ortho(W, H);  // looks down -z: a +z normal faces the light
  std::vector<RasterTriangle> tris = {tri({1, 1, 0}, {15, 1, 0}, {1, 15, 0}),
                                      tri({15, 15, 1}, {1, 15, 1}, {15, 1, 1}),
                                      tri({1, 1, 2}, {1, 15, 2}, {15, 1, 2})};
  auto drawn = [&](FaceCulling c) {
    RasterFilter f;
    f.culling = c;
    FragmentLists l = render_fragment_lists(tris, view, f);
    std::vector<uint32_t> seen;
    for (const Fragment& fr : l.fragments)
      if (std::find(seen.begin(), seen.end(), fr.triangle) == seen.end()) seen.push_back(fr.triangle);
    std::sort(seen.begin(), seen.end());
    return seen;
  };
  EXPECT_EQ(drawn(FaceCulling::None), (std::vector<uint32_t>{0, 1, 2}));
  EXPECT_EQ(drawn(FaceCulling::Back), (std::vector<uint32_t>{0, 1}));
  EXPECT_EQ(drawn(FaceCulling::Front), (std::vector<uint32_t>{2}));
}

TEST(Rasterizer, EmptyInputAndTinyImagesGiveEmptyOrFullMaps) {
  Rasterizer raster(8);
  DepthMap map;
  LightView view = unit_ortho(13, 7);  // smaller than a tile, not a power of two
  raster.depth_map({}, view, {}, &map);
  for (size_t i = 0; i < map.z.size(); ++i) {
    EXPECT_EQ(map.triangle[i], kNoTriangle);
    EXPECT_EQ(map.z[i], kInfinity);
  }
  // One big triangle over a 1 x 1 image covers its only centre.
  std::vector<RasterTriangle> tris = {tri({-5, -5, 0}, {20, -5, 0}, {-5, 20, 0})};
  raster.depth_map(tris, unit_ortho(1, 1), {}, &map);
  ASSERT_EQ(map.z.size(), 1u);
  EXPECT_EQ(map.triangle[0], 0u);
  EXPECT_FLOAT_EQ(map.z[0], 10.0f);  // the eye plane is at z = 10
  FragmentLists lists;
  raster.fragment_lists({}, view, {}, &lists);
  EXPECT_EQ(lists.total(), 0u);
  EXPECT_EQ(lists.offsets.size(), 13u * 7u + 1);
}

TEST(Rasterizer, ResultsDoNotDependOnTheThreadCount) {
  std::vector<RasterTriangle> tris = random_triangles(800, 23);
  LightView view = LightView::perspective({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 60, 200, 150, 1, 12);
  FragmentLists many = render_fragment_lists(tris, view);
  LayeredDepthMap many_layers = render_layered_depth_map(tris, view);
  ThreadLimit one(1);
  FragmentLists single = render_fragment_lists(tris, view);
  LayeredDepthMap single_layers = render_layered_depth_map(tris, view);
  EXPECT_EQ(many.offsets, single.offsets);
  ASSERT_EQ(many.fragments.size(), single.fragments.size());
  for (size_t i = 0; i < many.fragments.size(); ++i) {
    ASSERT_EQ(many.fragments[i].z, single.fragments[i].z);
    ASSERT_EQ(many.fragments[i].triangle, single.fragments[i].triangle);
  }
  EXPECT_EQ(many_layers.counts, single_layers.counts);
  for (int y = 0; y < view.height(); ++y)
    for (int x = 0; x < view.width(); ++x)
      for (int l = 0; l < many_layers.count(x, y); ++l) {
        ASSERT_EQ(many_layers.layers(x, y)[l].triangle, single_layers.layers(x, y)[l].triangle);
        ASSERT_EQ(many_layers.layers(x, y)[l].z, single_layers.layers(x, y)[l].z);
      }
}

// What happens to a triangle smaller than a texel (issue 34 part 2): coverage is sampled at
// texel centres, so a triangle that covers no centre writes nothing, and one that covers a
// centre writes the whole texel. Placed at random within its texel, a triangle of area a
// (in texels) covers the centre with probability a: over many, the texels written are their
// area, in expectation (point sampling is an unbiased estimate of coverage; what every method
// that filters the maps then averages). One right triangle of legs 1/4 texel (area 1/32) per
// texel of a 64 x 64 orthographic map, each at a random offset: about 4096 / 32 = 128 texels.
TEST(Rasterizer, SubTexelTrianglesCoverTheirShareOfTexelsInExpectation) {
  const int n = 64;
  const LightView view = LightView::orthographic({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, -4, 4, -4, 4, 1, 12, n, n);
  const float texel = 8.0f / n, leg = 0.25f * texel;
  Rng rng(34);
  std::vector<RasterTriangle> tris;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      // The triangle's corner uniform over the texel shifted by a leg, so that every position of
      // the centre relative to the triangle is equally likely.
      const float x = -4 + (i + rng.next_float()) * texel - leg, y = -4 + (j + rng.next_float()) * texel - leg;
      tris.push_back(tri({x, y, -5}, {x + leg, y, -5}, {x, y + leg, -5}, 1.0f, uint32_t(j * n + i)));
    }
  Rasterizer raster(16);
  DepthBinMasks masks;
  raster.depth_bin_masks(tris, view, {}, DepthBins{1.0f, 1.0f, 11}, &masks);
  int covered = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) covered += masks.at(x, y) != 0;
  // Binomial(4096, 1/32): mean 128, standard deviation 11.1; four of them either side.
  EXPECT_NEAR(covered, 128, 45);
  EXPECT_GT(covered, 0);
}

TEST(Rasterizer, DepthBinMasksAreTheBinsOfTheFragmentLists) {
  // Every fragment's bin, from the sorted fragment lists (the same depths), ORed per texel;
  // depths beyond the bins' ends clamp into the first and last bin.
  std::vector<RasterTriangle> tris = random_triangles(100, 23);
  for (bool perspective : {true, false}) {
    LightView view = perspective ? random_scene_view()
                                 : LightView::orthographic({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, -5, 5, -4, 4, 1, 12, 64, 48);
    Rasterizer raster(16);
    FragmentLists lists;
    raster.fragment_lists(tris, view, {}, &lists);
    DepthBins bins{3.0f, 0.37f, 13};  // [3, 7.81): some fragments before, some after
    DepthBinMasks masks;
    raster.depth_bin_masks(tris, view, {}, bins, &masks);
    EXPECT_TRUE(masks.nearest.empty());
    // With each bin's nearest depth (occlusion textures' own slice): the same masks, and the
    // smallest depth of the bin's fragments, 0 in an empty bin. Twice: a second render into the
    // same masks clears what the first left.
    DepthBinMasks nearest;
    bins.nearest = true;
    raster.depth_bin_masks(tris, view, {}, bins, &nearest);
    raster.depth_bin_masks(tris, view, {}, bins, &nearest);
    ASSERT_EQ(nearest.nearest.size(), static_cast<size_t>(view.width()) * view.height() * bins.count);
    ASSERT_EQ(masks.width, view.width());
    ASSERT_EQ(masks.height, view.height());
    EXPECT_EQ(raster.stats().fragments, lists.total());
    int before = 0, after = 0, multi = 0;
    const size_t plane = static_cast<size_t>(view.width()) * view.height();
    for (int y = 0; y < view.height(); ++y)
      for (int x = 0; x < view.width(); ++x) {
        uint32_t expect = 0;
        std::vector<float> lowest(bins.count, 0.0f);
        for (const Fragment& f : lists.at(x, y)) {
          float b = (f.z - bins.first) / bins.width;
          int k = b <= 0 ? 0 : std::min(bins.count - 1, int(b));
          before += b < 0;
          after += b >= bins.count;
          expect |= 1u << k;
          if (lowest[k] == 0.0f || f.z < lowest[k]) lowest[k] = f.z;
        }
        multi += std::popcount(expect) > 1;
        EXPECT_EQ(masks.at(x, y), expect) << x << "," << y;
        EXPECT_EQ(nearest.at(x, y), expect) << x << "," << y;
        for (int k = 0; k < bins.count; ++k)
          EXPECT_EQ(nearest.nearest[k * plane + nearest.index(x, y)], lowest[k]) << x << "," << y << " bin " << k;
      }
    EXPECT_GT(before, 0);
    EXPECT_GT(after, 0);
    EXPECT_GT(multi, 300);
  }
  DepthBinMasks masks;
  Rasterizer raster;
  EXPECT_THROW(raster.depth_bin_masks(tris, random_scene_view(), {}, DepthBins{0, 1, 33}, &masks), Error);
  EXPECT_THROW(raster.depth_bin_masks(tris, random_scene_view(), {}, DepthBins{0, 0, 4}, &masks), Error);
}

TEST(Rasterizer, DepthBinMasksPerTileBinEachTexelByItsTilesBins) {
  // DepthBins::tiles (occlusion-textures' light-space tiles): each tile of texels bins its
  // fragments by its own start and width. Tiles smaller than the rasterizer's (a bins record per
  // texel), as large (one per raster tile) and larger, on an image whose last tiles are cut.
  std::vector<RasterTriangle> tris = random_triangles(100, 29);
  const LightView view = LightView::orthographic({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, -5, 5, -4, 4, 1, 12, 72, 56);
  FragmentLists lists;
  Rasterizer(16).fragment_lists(tris, view, {}, &lists);
  for (int side : {8, 16, 32}) {
    const int columns = (view.width() + side - 1) / side, rows = (view.height() + side - 1) / side;
    std::vector<Vec2f> tiles;
    for (int i = 0; i < columns * rows; ++i) tiles.push_back(Vec2f(2.0f + 0.5f * float(i % 5), 0.2f + 0.05f * float(i % 7)));
    DepthBins bins{3.0f, 0.37f, 13};
    bins.tiles = tiles;
    bins.tile_side = side;
    Rasterizer raster(16);
    DepthBinMasks masks;
    raster.depth_bin_masks(tris, view, {}, bins, &masks);
    int multi = 0;
    for (int y = 0; y < view.height(); ++y)
      for (int x = 0; x < view.width(); ++x) {
        const Vec2f t = tiles[size_t(y / side) * columns + x / side];
        uint32_t expect = 0;
        for (const Fragment& f : lists.at(x, y)) {
          const float b = (f.z - t.x) / t.y;
          expect |= 1u << (b <= 0 ? 0 : std::min(bins.count - 1, int(b)));
        }
        multi += std::popcount(expect) > 1;
        ASSERT_EQ(masks.at(x, y), expect) << x << "," << y << " tiles of " << side;
      }
    EXPECT_GT(multi, 300) << side;
  }
  // Tiles that do not fit the image, or are not a power of two a side.
  std::vector<Vec2f> three(3, Vec2f(1, 1));
  DepthBins bad{0, 1, 4};
  bad.tiles = three;
  bad.tile_side = 32;
  DepthBinMasks masks;
  Rasterizer raster;
  EXPECT_THROW(raster.depth_bin_masks(tris, view, {}, bad, &masks), Error);
  std::vector<Vec2f> six(6, Vec2f(1, 1));
  bad.tiles = six;
  bad.tile_side = 24;
  EXPECT_THROW(raster.depth_bin_masks(tris, view, {}, bad, &masks), Error);
  bad.tile_side = 32;
  EXPECT_NO_THROW(raster.depth_bin_masks(tris, view, {}, bad, &masks));  // 3 x 2 tiles of 32
  six[4] = Vec2f(1, 0);
  EXPECT_THROW(raster.depth_bin_masks(tris, view, {}, bad, &masks), Error);  // a tile without width
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
