#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <set>

#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/shadow/light_samples.h"
#include "penumbra/shadow/soft_shadow_volumes/crossing_kernel.h"
#include "penumbra/shadow/soft_shadow_volumes/depth_complexity.h"
#include "penumbra/shadow/soft_shadow_volumes/silhouette_edges.h"
#include "penumbra/testing/memory_cases.h"
#include "penumbra/testing/method_runs.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using namespace penumbra::testing;

Scene single_object_scene(TriangleMesh mesh) {
  Scene s;
  s.objects.push_back(object(std::move(mesh)));
  s.lights.push_back(rect_light_down({0, 5, 0}, 0.1f, 0.1f));
  s.finalize();
  return s;
}

// The set of edges as unordered vertex pairs (rounded to thousandths), for comparing.
std::set<std::pair<std::array<int, 3>, std::array<int, 3>>> edge_set(const std::vector<ssv::SilhouetteEdge>& edges) {
  auto q = [](Vec3f p) {
    return std::array<int, 3>{static_cast<int>(std::lround(p.x * 1000)), static_cast<int>(std::lround(p.y * 1000)),
                              static_cast<int>(std::lround(p.z * 1000))};
  };
  std::set<std::pair<std::array<int, 3>, std::array<int, 3>>> out;
  for (const ssv::SilhouetteEdge& e : edges) out.insert(std::minmax(q(e.a), q(e.b)));
  return out;
}

TEST(SoftShadowVolumesSilhouettes, CubeSeenFromALightGivesTheClosedFormSilhouette) {
  const Scene scene = single_object_scene(box({0, 0, 0}, {1, 1, 1}));
  // A small light beyond the +x and +y faces, between the z planes: the faces it sees are +x
  // and +y; the silhouette is the loop around both: 8 edges of the two faces less the one
  // they share.
  {
    const auto edges = ssv::potential_silhouettes(scene, {{3, 2.5f, 0.5f}, 0.05f});
    for (const auto& e : edges) EXPECT_EQ(e.triangles, 2u);
    const auto got = edge_set(edges);
    // Each face's four edges; a closed-form list: an edge lies on a face iff both endpoints
    // have that face's coordinate.
    std::set<std::pair<std::array<int, 3>, std::array<int, 3>>> want;
    for (int i = 0; i < 8; ++i)
      for (int j = i + 1; j < 8; ++j) {
        const std::array<int, 3> a{(i & 1) * 1000, (i >> 1 & 1) * 1000, (i >> 2 & 1) * 1000};
        const std::array<int, 3> b{(j & 1) * 1000, (j >> 1 & 1) * 1000, (j >> 2 & 1) * 1000};
        int differ = 0;
        for (int k = 0; k < 3; ++k) differ += a[k] != b[k];
        if (differ != 1) continue;  // not a cube edge
        const bool on_px = a[0] == 1000 && b[0] == 1000, on_py = a[1] == 1000 && b[1] == 1000;
        if (on_px != on_py) want.insert(std::minmax(a, b));  // on exactly one lit face
      }
    EXPECT_EQ(want.size(), 6u);
    EXPECT_EQ(got, want);
  }
  // Beyond a corner: three faces seen, the silhouette is the hexagon of 6 edges.
  EXPECT_EQ(ssv::potential_silhouettes(scene, {{3, 3, 3}, 0.05f}).size(), 6u);
  // Straight above the top face: its 4 edges.
  EXPECT_EQ(ssv::potential_silhouettes(scene, {{0.5f, 4, 0.5f}, 0.05f}).size(), 4u);
  // A light as wide as the cube straddles the side faces' planes: the top's 4 edges, the 4
  // vertical ones, and the side faces' diagonals become potential silhouettes too.
  EXPECT_GT(ssv::potential_silhouettes(scene, {{0.5f, 4, 0.5f}, 2.0f}).size(), 8u);
}

TEST(SoftShadowVolumesSilhouettes, APlanarLightIsTighterThanItsBall) {
  // A 0.8 x 0.8 rect light high above the cube's top face: the side faces' planes (0.5 from
  // its centre) miss the rectangle but cut its ball (radius 0.57): the rectangle keeps only
  // the top's 4 edges, the ball the side faces' diagonals and the vertical edges too.
  const Scene scene = single_object_scene(box({0, 0, 0}, {1, 1, 1}));
  const AreaLight light = rect_light_down({0.5f, 4, 0.5f}, 0.8f, 0.8f);
  const ssv::LightRegion region = ssv::light_region(light);
  ASSERT_TRUE(region.planar);
  EXPECT_EQ(ssv::potential_silhouettes(scene, region).size(), 4u);
  EXPECT_GT(ssv::potential_silhouettes(scene, {light.center, light.extent_radius()}).size(), 4u);
}

TEST(SoftShadowVolumesSilhouettes, OpenQuadHasItsFourBoundaryEdges) {
  const Scene scene = single_object_scene(quad_y(1, 0, 1, 0, 1));
  const auto edges = ssv::potential_silhouettes(scene, {{0.5f, 4, 0.5f}, 0.5f});
  // The four borders (one triangle each); the diagonal is flat as seen from the light.
  ASSERT_EQ(edges.size(), 4u);
  for (const auto& e : edges) EXPECT_EQ(e.triangles, 1u);
}

// Objects are found in parallel: the edges are each object's, in the scene's order, the same
// list whatever the thread count; a mesh stored without shared vertices (every triangle its own
// three) is welded by position into the same edges as the indexed one.
TEST(SoftShadowVolumesSilhouettes, ObjectsComeInTheScenesOrderAndSplitVerticesAreWelded) {
  // Six boxes in a row (odd ones as triangle soups when `soups`) and an open quad above them.
  auto make = [](bool soups) {
    Scene scene;
    for (int k = 0; k < 6; ++k) {
      const float x = 2.0f * static_cast<float>(k);
      TriangleMesh m = box({x, 0, 0}, {x + 1, 1, 1});
      if (soups && k % 2 == 1) {
        TriangleMesh soup;
        for (size_t t = 0; t < m.triangle_count(); ++t)
          for (int c = 0; c < 3; ++c) {
            soup.indices.push_back(static_cast<uint32_t>(soup.positions.size()));
            soup.positions.push_back(m.vertex(t, c));
          }
        m = std::move(soup);
      }
      scene.objects.push_back(object(std::move(m)));
    }
    scene.objects.push_back(object(quad_y(2, 0, 11, 3, 4)));
    scene.lights.push_back(rect_light_down({5, 6, 0.5f}, 1, 1));
    scene.finalize();
    return scene;
  };
  const Scene scene = make(true);
  const ssv::LightRegion region = ssv::light_region(scene.lights[0]);
  std::vector<ssv::SilhouetteEdge> one_thread;
  {
    ThreadLimit limit(1);
    one_thread = ssv::potential_silhouettes(scene, region);
  }
  const auto all_threads = ssv::potential_silhouettes(scene, region);
  ASSERT_EQ(one_thread.size(), all_threads.size());
  for (size_t i = 0; i < one_thread.size(); ++i) {
    const ssv::SilhouetteEdge& a = one_thread[i];
    const ssv::SilhouetteEdge& b = all_threads[i];
    EXPECT_TRUE(a.a == b.a && a.b == b.b && a.w[0] == b.w[0] && a.w[1] == b.w[1] && a.triangles == b.triangles) << i;
  }
  // Object by object: the boxes left to right (box k's edges within x in [2k, 2k + 1], each
  // with its two triangles, soup or not, and the indexed box's edges), the quad's four borders
  // last.
  const auto indexed = ssv::potential_silhouettes(make(false), region);
  auto in_box = [](const ssv::SilhouetteEdge& e, float x) {
    return e.a.y <= 1 && e.b.y <= 1 && std::min(e.a.x, e.b.x) >= x && std::max(e.a.x, e.b.x) <= x + 1;
  };
  size_t i = 0;
  for (int k = 0; k < 6; ++k) {
    const float x = 2.0f * static_cast<float>(k);
    std::vector<ssv::SilhouetteEdge> got, want;
    while (i < one_thread.size() && in_box(one_thread[i], x)) {
      EXPECT_EQ(one_thread[i].triangles, 2u);
      got.push_back(one_thread[i++]);
    }
    for (const auto& e : indexed)
      if (in_box(e, x)) want.push_back(e);
    EXPECT_FALSE(got.empty()) << "box " << k;
    EXPECT_EQ(edge_set(got), edge_set(want)) << "box " << k;
  }
  ASSERT_EQ(one_thread.size() - i, 4u);
  for (; i < one_thread.size(); ++i) EXPECT_EQ(one_thread[i].triangles, 1u);
}

// The number of triangles the segment o-l crosses, in double (brute force).
int crossings(const Scene& scene, Vec3f o, Vec3f l) {
  int count = 0;
  auto det = [](Vec3f a, Vec3f b, Vec3f c, Vec3f d) {
    const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z, vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z,
                 wx = d.x - a.x, wy = d.y - a.y, wz = d.z - a.z;
    return ux * (vy * wz - vz * wy) - uy * (vx * wz - vz * wx) + uz * (vx * wy - vy * wx);
  };
  for (const SceneObject& obj : scene.objects)
    for (size_t t = 0; t < obj.mesh.triangle_count(); ++t) {
      const Vec3f a = obj.mesh.vertex(t, 0), b = obj.mesh.vertex(t, 1), c = obj.mesh.vertex(t, 2);
      const double so = det(a, b, c, o), sl = det(a, b, c, l);
      if ((so > 0) == (sl > 0)) continue;
      const double x = det(o, l, a, b), y = det(o, l, b, c), z = det(o, l, c, a);
      if ((x > 0 && y > 0 && z > 0) || (x < 0 && y < 0 && z < 0)) ++count;
    }
  return count;
}

// D over the light samples from o: the brute-force count at the reference sample plus every
// potential silhouette's update (the method's own loop, without the hierarchy).
std::vector<int32_t> depth_by_edges(const Scene& scene, const std::vector<ssv::SilhouetteEdge>& edges,
                                    const LightSamples& ls, Vec3f o, int reference) {
  const int n = ls.size();
  const size_t padded = ssv::padded_samples(n);
  std::vector<float> x(padded, 0.0f), y(padded, 0.0f), z(padded, 0.0f);
  for (int i = 0; i < n; ++i) x[i] = ls.points[i].x - o.x, y[i] = ls.points[i].y - o.y, z[i] = ls.points[i].z - o.z;
  std::vector<int32_t> d(padded, crossings(scene, o, ls.points[reference]));
  for (const auto& e : edges) ssv::add_edge_crossings(e, o, ls.points[reference] - o, {x.data(), y.data(), z.data(), n}, d.data());
  d.resize(n);
  return d;
}

TEST(SoftShadowVolumesDepthComplexity, EqualsTheSurfacesEachSegmentCrosses) {
  // Two closed boxes (one inside the other's shadow) and an open quad above them, under a
  // rect light: from random points below, D(l) from one reference count plus the edges'
  // updates is the brute-force number of triangles crossed, for every light sample; it is
  // never negative, even for the closed boxes (each is entered and left), and the same
  // whichever sample is the reference.
  Scene scene;
  scene.objects.push_back(object(box({-0.5f, 0.5f, -0.4f}, {0.3f, 0.9f, 0.2f})));
  scene.objects.push_back(object(box({0.1f, 0.2f, 0.0f}, {0.6f, 0.4f, 0.5f})));
  scene.objects.push_back(object(quad_y(1.4f, -0.2f, 0.7f, -0.6f, 0.3f)));
  scene.lights.push_back(rect_light_down({0.1f, 2.5f, 0.0f}, 1.6f, 1.2f));
  scene.finalize();
  const AreaLight& light = scene.lights[0];
  const auto edges = ssv::potential_silhouettes(scene, ssv::light_region(light));
  const LightSamples ls = make_light_samples(light, 60, 3, 0, 0);  // not a multiple of the padding
  Rng rng(41);
  long compared = 0, equal = 0, penumbra_points = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3f o{rng.next_float() * 3 - 1.5f, rng.next_float() * 0.15f, rng.next_float() * 3 - 1.5f};
    const std::vector<int32_t> d = depth_by_edges(scene, edges, ls, o, 0);
    const std::vector<int32_t> d_other = depth_by_edges(scene, edges, ls, o, 37);
    int lit = 0;
    for (int i = 0; i < ls.size(); ++i) {
      const int truth = crossings(scene, o, ls.points[i]);
      ++compared;
      equal += d[i] == truth;
      EXPECT_GE(d[i], 0);
      EXPECT_EQ(d[i], d_other[i]) << trial << " " << i;
      lit += d[i] == 0;
    }
    penumbra_points += lit > 0 && lit < ls.size();
  }
  std::printf("depth complexity by edges vs brute force: %ld of %ld equal, %ld points in penumbra\n", equal,
              compared, penumbra_points);
  EXPECT_EQ(equal, compared);
  EXPECT_GT(penumbra_points, 20);
}

TEST(SoftShadowVolumesDepthComplexity, NonSilhouetteEdgesChangeNothing) {
  // An edge inside a flat sheet (two coplanar triangles): k_e = 0 from every point.
  ssv::SilhouetteEdge e{{0, 1, 0}, {1, 1, 0}, {{0.5f, 1, 1}, {0.5f, 1, -1}}, 2};
  Rng rng(3);
  for (int i = 0; i < 100; ++i) {
    const Vec3f o{rng.next_float() * 4 - 2, rng.next_float() * 4 - 2, rng.next_float() * 4 - 2};
    EXPECT_EQ(ssv::edge_weight(e, o), 0);
  }
  // A fold (both triangles on one side): 2 in magnitude; a boundary edge: 1.
  e.w[1] = {0.5f, 2, 1};
  EXPECT_EQ(std::abs(ssv::edge_weight(e, {0.5f, -1, 3})), 2);
  e.triangles = 1;
  EXPECT_EQ(std::abs(ssv::edge_weight(e, {0.5f, -1, 3})), 1);
}

// ssv-rt with n light samples against Embree's rays to the same points, and the exactness every
// test below asserts: every view sample equal, but for rounding's one sample in a thousand.
struct ExactRun {
  std::vector<float> v;
  MethodStats stats;
  Agreement g;
};
ExactRun expect_equal_to_embree(const SceneRun& r, int n, const std::string& what) {
  ExactRun out;
  out.v = run_method(r, "ssv-rt", n, {}, &out.stats);
  const LightSamples pts = make_light_samples(r.scene.lights[0], n, 0, 0, 0);
  const std::vector<float> e = embree_to_points(r, pts.points);
  out.g = agreement(out.v, e);
  EXPECT_GE(out.g.equal_fraction, 0.999) << what << ", " << worst_sample(r, out.v, e);
  EXPECT_LE(out.g.max_diff, 1.0f / n + 1e-6f) << what << ", " << worst_sample(r, out.v, e);
  return out;
}

class SoftShadowVolumesScenes : public ::testing::TestWithParam<std::string> {};

TEST_P(SoftShadowVolumesScenes, EqualsEmbreeToTheSameLightPoints) {
  const SceneRun r = load_scene_at(GetParam(), 96);
  const int n = 64;
  // Every view sample, those on thin two-sided leaves (plant, foliage, leaf-cards) included.
  const ExactRun run = expect_equal_to_embree(r, n, GetParam());
  const std::vector<float>& v = run.v;
  std::printf("ssv-rt N=%d vs Embree to the same points, %s: %.5f equal, max |dV| %.5f, %zu silhouette edges\n", n,
              GetParam().c_str(), run.g.equal_fraction, run.g.max_diff, run.stats.extra["silhouette_edges"].get<size_t>());
  // A penumbra exists, and afsm (the same points) agrees.
  EXPECT_GT(std::count_if(v.begin(), v.end(), [](float x) { return x > 0.05f && x < 0.95f; }), 50);
  const std::vector<float> a = run_method(r, "afsm", n, {"resolution=192"});
  EXPECT_GE(agreement(v, a).equal_fraction, 0.998) << worst_sample(r, v, a);
}

// foliage and leaf-cards: alpha-masked casters, tested per light sample (issue 20).
INSTANTIATE_TEST_SUITE_P(SoftShadowVolumes, SoftShadowVolumesScenes,
                         ::testing::Values("bunny", "knot", "contact", "plant", "foliage", "leaf-cards"));

TEST(SoftShadowVolumesShapes, EqualsEmbreeForEveryLightShapeWithOpenClosedAndSemiTransparentCasters) {
  for (LightShape shape : {LightShape::Rect, LightShape::Disk, LightShape::Sphere, LightShape::Ellipsoid}) {
    AreaLight light = rect_light_down({0.3f, 2.2f, 0.1f}, 1.0f, 0.6f);
    light.shape = shape;
    light.radius = 0.45f;
    light.radii = {0.6f, 0.25f, 0.2f};
    // An open quad (boundary edges), a closed box over the ground, and two semi-transparent
    // quads (opacity 0.5 and 0.3) overlapping above it: the reference attenuates a ray by
    // (1 - opacity) per crossing, and so must ssv-rt.
    const SceneRun r = build_scene_run(ground_scene({object(quad_y(0.9f, -1.0f, 0.2f, -0.6f, 0.4f)),
                                                     object(box({0.4f, 0, -0.5f}, {0.9f, 0.6f, 0.2f})),
                                                     object(quad_y(1.2f, 0.2f, 1.0f, -0.7f, 0.0f), Vec3f(0.8f), 0.5f),
                                                     object(quad_y(1.4f, 0.5f, 1.3f, -0.3f, 0.3f), Vec3f(0.8f), 0.3f)},
                                                    light, 64));
    ASSERT_FALSE(r.scene.objects[1].closed);
    ASSERT_TRUE(r.scene.objects[2].closed);
    const ExactRun run = expect_equal_to_embree(r, 100, to_string(shape));
    const std::vector<float>& v = run.v;
    EXPECT_EQ(run.stats.extra["partial_casters"].get<int>(), 4);
    // Some light passes through one or both of the semi-transparent quads only.
    EXPECT_GT(std::count_if(v.begin(), v.end(), [](float x) { return std::abs(x * 100 - std::round(x * 100)) > 1e-3f; }), 50)
        << to_string(shape);
  }
}

// Casters that meet a one-sided light: a wall through the middle of the light (half of it above
// the light's plane) and a ceiling flush with the light. The wall cuts the light along a line
// that is no edge of its mesh; clipped just in front of the plane it ends in boundary edges there,
// and the sweep stays exact (before: mean |dV| 0.215 against the ground truth on such a scene,
// `reference` 0.013). The ceiling, wholly on the plane, has no edge.
TEST(SoftShadowVolumesShapes, CastersThroughOrBehindTheLightAreClippedToItsFront) {
  for (LightShape shape : {LightShape::Rect, LightShape::Disk}) {
    AreaLight light = rect_light_down({0.0f, 2.0f, 0.0f}, 1.0f, 0.8f);
    light.shape = shape;
    light.radius = 0.5f;
    // The wall: an open quad in the plane x = 0 (a solid one would hold light samples inside it,
    // which rays from its own faces see from within).
    TriangleMesh wall;
    wall.positions = {{0, 1.2f, -1.0f}, {0, 1.2f, 1.0f}, {0, 2.6f, 1.0f}, {0, 2.6f, -1.0f}};
    wall.indices = {0, 1, 2, 0, 2, 3};
    Scene scene = ground_scene({object(std::move(wall)),
                                object(quad_y(2.0f, -2.0f, 2.0f, -2.0f, 2.0f)),
                                object(box({0.5f, 0, -0.3f}, {0.9f, 0.5f, 0.2f}))},
                               light, 64);
    // Under the ceiling, beside the wall, looking down at the ground.
    scene.camera.eye = {1.2f, 1.8f, 0.2f};
    scene.camera.target = {0.0f, 0.0f, 0.0f};
    scene.camera.up = {0, 0, -1};
    scene.camera.fov_y = 80;
    const SceneRun r = build_scene_run(std::move(scene));
    const ExactRun run = expect_equal_to_embree(r, 64, to_string(shape));
    const std::vector<float>& v = run.v;
    std::printf("%s light, a wall through it and a ceiling: %.5f equal, max |dV| %.5f\n", to_string(shape),
                run.g.equal_fraction, run.g.max_diff);
    // The wall hides part of the light from most of the ground: a penumbra.
    EXPECT_GT(std::count_if(v.begin(), v.end(), [](float x) { return x > 0.05f && x < 0.95f; }), 200) << to_string(shape);
  }
}

TEST(SoftShadowVolumesShapes, SameSeedSameImageAndNewFramesNewSamples) {
  const SceneRun r = load_scene_at("contact", 32);
  const std::vector<float> a = run_method(r, "ssv-rt", 16, {}, nullptr, 5);
  EXPECT_EQ(a, run_method(r, "ssv-rt", 16, {}, nullptr, 5));
  EXPECT_NE(a, run_method(r, "ssv-rt", 16, {}, nullptr, 6));
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// The memory-estimate checks (render/memory_estimate_test.cpp, testing/memory_cases.h).
const testing::MemoryCaseRegistration kSsvRtMemory(
    "ssv-rt", {"--spp", "triangles"},
    {// The silhouette edges: many triangles.
     {"ssv-rt", {}, 16, /*many_triangles=*/true}});

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
