// The GPU's scene and ray tracer against Embree, ray for ray: BVHs from Embree's builder,
// closest hits (object, triangle, distance, barycentrics), transmittance through alpha masks and
// semi-transparent casters, shared meshes as instances (mirrored ones included), refits.
#include "penumbra/gpu/gpu_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "penumbra/core/rng.h"
#include "penumbra/gpu/bvh_builder.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/gpu/ray_queries.h"
#include "penumbra/testing/method_runs.h"
#include "penumbra/testing/test_scenes.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra::gpu {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::GpuTest;

// Every item once; every child box holds its subtree; depth within the traversal's stack.
void check_bvh(const FlatBvh& bvh, std::span<const Bounds3f> boxes) {
  ASSERT_EQ(bvh.order.size(), boxes.size());
  std::vector<int> seen(boxes.size(), 0);
  for (uint32_t i : bvh.order) ++seen.at(i);
  for (int s : seen) ASSERT_EQ(s, 1);
  auto contains = [](const Bounds3f& outer, const Bounds3f& inner) {
    return outer.lo.x <= inner.lo.x && outer.lo.y <= inner.lo.y && outer.lo.z <= inner.lo.z &&
           outer.hi.x >= inner.hi.x && outer.hi.y >= inner.hi.y && outer.hi.z >= inner.hi.z;
  };
  std::function<int(uint32_t)> walk = [&](uint32_t node) -> int {
    const shader::GpuBvhNode& n = bvh.nodes.at(node);
    int depth = 0;
    for (int k = 0; k < 2; ++k) {
      const uint32_t child = k ? n.child1 : n.child0, count = k ? n.count1 : n.count0;
      const Bounds3f box{k ? n.lo1 : n.lo0, k ? n.hi1 : n.hi0};
      if (child == shader::kEmptyChild) continue;
      if (count > 0) {
        for (uint32_t i = 0; i < count; ++i) EXPECT_TRUE(contains(box, boxes[bvh.order.at(child + i)]));
        continue;
      }
      const shader::GpuBvhNode& c = bvh.nodes.at(child);
      EXPECT_GT(child, node) << "children follow their parents";
      if (c.child0 != shader::kEmptyChild) EXPECT_TRUE(contains(box, Bounds3f{c.lo0, c.hi0}));
      if (c.child1 != shader::kEmptyChild) EXPECT_TRUE(contains(box, Bounds3f{c.lo1, c.hi1}));
      depth = std::max(depth, 1 + walk(child));
    }
    return depth;
  };
  EXPECT_LE(walk(0), kMaxBvhDepth + 1);
}

std::vector<Bounds3f> random_boxes(size_t n, uint64_t seed, float shift = 0) {
  Rng rng(seed);
  std::vector<Bounds3f> boxes(n);
  for (Bounds3f& b : boxes) {
    const Vec3f c(rng.next_float() * 10 + shift, rng.next_float() * 10, rng.next_float() * 10);
    const Vec3f h(rng.next_float() * 0.3f, rng.next_float() * 0.3f, rng.next_float() * 0.3f);
    b = Bounds3f{c - h, c + h};
  }
  return boxes;
}

TEST(GpuBvhBuilder, FlattensEmbreesTreeWithEveryItemOnceAndRefits) {
  for (size_t n : {0u, 1u, 2u, 7u, 1000u, 20000u}) {
    const std::vector<Bounds3f> boxes = random_boxes(n, n);
    FlatBvh bvh = build_bvh(boxes, 4);
    check_bvh(bvh, boxes);
    if (n == 0) continue;
    const std::vector<Bounds3f> moved = random_boxes(n, n + 1, 3.0f);
    refit_bvh(bvh, moved);
    check_bvh(bvh, moved);
  }
}

// Random rays through a scene's bounds: from outside toward a point inside.
std::vector<Ray> random_rays(const Scene& scene, size_t n, uint64_t seed) {
  const Bounds3f b = scene.bounds();
  const Vec3f c = b.center(), d = b.diagonal();
  const float radius = length(d);
  Rng rng(seed);
  std::vector<Ray> rays(n);
  for (Ray& r : rays) {
    const Vec3f target = c + Vec3f((rng.next_float() - 0.5f) * d.x, (rng.next_float() - 0.5f) * d.y * 0.5f,
                                   (rng.next_float() - 0.5f) * d.z);
    Vec3f from = normalize(Vec3f(rng.next_float() - 0.5f, rng.next_float() * 0.8f + 0.1f, rng.next_float() - 0.5f));
    r.org = c + from * radius;
    r.dir = normalize(target - r.org);
  }
  return rays;
}

void expect_same_hits(const Scene& scene, const RayTracer& embree, const GpuScene& gpu, size_t n) {
  const std::vector<Ray> rays = random_rays(scene, n, 7);
  std::vector<Hit> want(n);
  embree.intersect(rays, want);
  const std::vector<Hit> got = trace_closest(gpu, rays);
  size_t same = 0, hits = 0;
  for (size_t i = 0; i < n; ++i) {
    if (want[i].object != Hit::kMiss) ++hits;
    if (got[i].object != want[i].object || (want[i].object != Hit::kMiss && got[i].prim != want[i].prim)) continue;
    ++same;
    if (want[i].object == Hit::kMiss) continue;
    EXPECT_NEAR(got[i].t, want[i].t, 1e-4f * std::max(1.0f, want[i].t)) << "ray " << i;
    EXPECT_NEAR(got[i].u, want[i].u, 1e-3f) << "ray " << i;
    EXPECT_NEAR(got[i].v, want[i].v, 1e-3f) << "ray " << i;
  }
  EXPECT_GT(hits, n / 4) << "the rays must hit something";
  EXPECT_GE(static_cast<double>(same), 0.999 * n) << same << " of " << n << " rays hit the same triangle";
}

class GpuTracer : public GpuTest {};

TEST_F(GpuTracer, ClosestHitsEqualEmbreesOnTheBunny) {
  const penumbra::testing::SceneRun run = penumbra::testing::load_scene_at("bunny", 16);
  const GpuScene gpu(device(), run.scene);
  EXPECT_EQ(gpu.blas_count(), 1);
  expect_same_hits(run.scene, *run.tracer, gpu, 20000);
}

TEST_F(GpuTracer, CameraRaysPassThroughAlphaMasksAsEmbreesDo) {
  const penumbra::testing::SceneRun run = penumbra::testing::load_scene_at("foliage", 16);
  const GpuScene gpu(device(), run.scene);
  EXPECT_TRUE(gpu.has_transparency());
  expect_same_hits(run.scene, *run.tracer, gpu, 20000);
}

// Segments between random points of the scene: transmittance as Embree's filters give it.
void expect_same_transmittance(const std::string& name) {
  const penumbra::testing::SceneRun run = penumbra::testing::load_scene_at(name, 16);
  const GpuScene gpu(Device::get(-1), run.scene);
  const Bounds3f b = run.scene.bounds();
  Rng rng(11);
  std::vector<ShadowRay> rays(20000);
  for (ShadowRay& r : rays) {
    auto point = [&] {
      return b.lo + Vec3f(rng.next_float() * (b.hi.x - b.lo.x), rng.next_float() * (b.hi.y - b.lo.y),
                          rng.next_float() * (b.hi.z - b.lo.z));
    };
    const Vec3f p = point(), q = point() + Vec3f(0, 0.5f * (b.hi.y - b.lo.y), 0);
    r = shadow_ray_to(p, Vec3f(0, 1, 0), q);
  }
  std::vector<float> want(rays.size());
  run.tracer->transmittance(rays, want);
  const std::vector<float> got = trace_transmittance(gpu, rays);
  size_t same = 0, partial = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    same += std::abs(got[i] - want[i]) <= 1e-4f;
    partial += want[i] > 0 && want[i] < 1;
  }
  EXPECT_GE(static_cast<double>(same), 0.999 * rays.size()) << name << ": " << same << " of " << rays.size();
  if (name == "furball") EXPECT_GT(partial, rays.size() / 100) << "semi-transparent strands attenuate";
}

TEST_F(GpuTracer, TransmittanceEqualsEmbreesThroughAlphaMasks) { expect_same_transmittance("foliage"); }
TEST_F(GpuTracer, TransmittanceEqualsEmbreesThroughSemiTransparentCasters) { expect_same_transmittance("furball"); }

// One mesh placed five times (one placement mirrors), shared as an Embree instance and on the GPU.
Scene instanced_scene() {
  Scene s = penumbra::testing::ground_scene({}, penumbra::testing::rect_light_down({0, 3, 0}, 1, 1));
  auto shared = std::make_shared<TriangleMesh>(penumbra::testing::box({-0.3f, 0, -0.2f}, {0.3f, 0.5f, 0.2f}));
  const Mat4 placements[5] = {Mat4::translate({-2, 0, -2}), Mat4::translate({2, 0, 1}) * Mat4::rotate_y(30),
                              Mat4::translate({0, 0, 2}) * Mat4::scale({-1, 1.5f, 1}), Mat4::translate({-1, 0, 1}),
                              Mat4::translate({1.5f, 0.2f, -1.5f}) * Mat4::rotate_x(40) * Mat4::scale({0.7f, 0.7f, 0.7f})};
  for (const Mat4& m : placements) {
    SceneObject o = penumbra::testing::object(*shared);
    o.mesh.transform(m);
    o.shared_mesh = shared;
    o.placement = m;
    s.objects.push_back(o);
  }
  s.finalize();
  return s;
}

TEST_F(GpuTracer, SharedMeshesAreOneBvhWithAnInstancePerPlacement) {
  const Scene scene = instanced_scene();
  const GpuScene gpu(device(), scene);
  EXPECT_EQ(gpu.blas_count(), 2);        // the ground's world BLAS and the box once
  EXPECT_EQ(gpu.instance_count(), 6u);  // the world BLAS and five placements
  // Against Embree on the same scene (instanced there too) and on its world meshes alone.
  const RayTracer embree(scene);
  expect_same_hits(scene, embree, gpu, 20000);
  Scene flat = scene;
  for (SceneObject& o : flat.objects) o.unshare();
  const RayTracer embree_flat(flat);
  expect_same_hits(flat, embree_flat, gpu, 20000);
}

TEST_F(GpuTracer, MovedObjectsAreRefitOrReplacedAndHitAsEmbreesDo) {
  Scene scene = instanced_scene();
  scene.objects.push_back(penumbra::testing::object(penumbra::testing::box({-0.2f, 0, -0.2f}, {0.2f, 1, 0.2f})));
  scene.finalize();
  const uint32_t own = static_cast<uint32_t>(scene.objects.size() - 1);
  const std::vector<uint32_t> movable = {1, own};
  GpuScene gpu(device(), scene, movable);
  EXPECT_EQ(gpu.blas_count(), 3);
  // Move the instance (its placement) and the object of its own (its vertices: a refit).
  const Mat4 shift = Mat4::translate({0.4f, 0.1f, -0.3f});
  SceneObject& inst = scene.objects[1];
  inst.placement = shift * inst.placement;
  inst.mesh = *inst.shared_mesh;
  inst.mesh.transform(inst.placement);
  scene.objects[own].mesh.transform(shift);
  gpu.update_objects(scene, movable);
  EXPECT_EQ(gpu.refits(), 1);
  const RayTracer embree(scene);
  expect_same_hits(scene, embree, gpu, 20000);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::gpu
