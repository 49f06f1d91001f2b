// Embree instances (issue 32): a mesh placed by several objects is built once, and every query
// through its instances gives what the same scene with its objects unshared gives: the object,
// its world triangle, the distance, the world normal and barycentrics; shadow rays' transmittance
// through materials that differ per object (alpha masks, opacity); moved instances.
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "penumbra/core/rng.h"
#include "penumbra/scene/shapes.h"
#include "penumbra/testing/test_scenes.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::instanced_scene;
using testing::unshared;

std::shared_ptr<const TriangleMesh> ball() { return std::make_shared<const TriangleMesh>(make_uv_sphere(0.4f, 48)); }

const AreaLight kLight = testing::rect_light_down({0.2f, 2.5f, -0.1f}, 1.0f, 0.8f);

// Random rays from above and from the sides through the grid of copies.
std::vector<Ray> random_rays(int n, uint64_t seed) {
  std::vector<Ray> rays;
  Rng rng(seed, 11);
  for (int i = 0; i < n; ++i) {
    const Vec2f a = rng.next_2d(), b = rng.next_2d();
    const float side = rng.next_float();
    Ray r;
    r.org = side < 0.5f ? Vec3f(-4.0f + 8.0f * a.x, 3.5f, -4.0f + 8.0f * a.y)
                        : Vec3f(-5.0f, 0.2f + 1.5f * a.x, -4.0f + 8.0f * a.y);
    const Vec3f target = {-3.2f + 6.4f * b.x, 0.4f + 0.9f * rng.next_float(), -3.2f + 6.4f * b.y};
    r.dir = normalize(target - r.org);
    rays.push_back(r);
  }
  return rays;
}

// Every closest hit of `a` equals `b`'s: the object and triangle (or a tie: two triangles of
// one object at one distance, an edge both contain), t within 1e-5 relative, the geometric
// normals in one direction, the barycentrics within rounding (`scene`: the world meshes both
// trace); and the shadow rays from the hits
// have the same transmittance. Returns the ties.
int expect_same_hits(const RayTracer& a, const RayTracer& b, const std::vector<Ray>& rays, const Scene& scene) {
  std::vector<Hit> ha(rays.size()), hb(rays.size());
  a.intersect(rays, ha);
  b.intersect(rays, hb);
  int ties = 0, hits = 0;
  std::vector<ShadowRay> shadow;
  for (size_t i = 0; i < rays.size(); ++i) {
    EXPECT_EQ(ha[i].object, hb[i].object) << i;
    if (ha[i].object != hb[i].object || ha[i].object == Hit::kMiss) continue;
    ++hits;
    EXPECT_NEAR(ha[i].t, hb[i].t, 1e-5f * hb[i].t) << i;
    if (ha[i].prim != hb[i].prim) {
      ++ties;
      continue;
    }
    const Vec3f na = normalize(ha[i].ng), nb = normalize(hb[i].ng);
    EXPECT_GT(dot(na, nb), 1.0f - 1e-5f) << i;
    EXPECT_NEAR(length(ha[i].ng), length(hb[i].ng), 1e-3f * length(hb[i].ng)) << i;
    // The barycentrics name the same point of the world triangle (within rounding: on the
    // sphere's thin polar triangles a rounding of the point is a larger one of u, v).
    const TriangleMesh& m = scene.objects[hb[i].object].mesh;
    auto point = [&](const Hit& h) {
      return m.vertex(h.prim, 0) * (1 - h.u - h.v) + m.vertex(h.prim, 1) * h.u + m.vertex(h.prim, 2) * h.v;
    };
    const Vec3f pb = point(hb[i]);
    EXPECT_LT(length(point(ha[i]) - pb), 1e-5f * (1.0f + length(pb))) << i;
    // Single-ray queries agree with the stream's.
    Hit single;
    EXPECT_TRUE(a.intersect(rays[i], &single));
    EXPECT_EQ(single.object, ha[i].object);
    const Vec3f p = rays[i].org + rays[i].dir * hb[i].t;
    shadow.push_back(shadow_ray_to(p, hb[i].ng, kLight.center + Vec3f(0.3f * (i % 3), 0, 0.2f * (i % 5))));
  }
  EXPECT_GT(hits, static_cast<int>(rays.size()) / 2);
  std::vector<float> ta(shadow.size()), tb(shadow.size());
  a.transmittance(shadow, ta);
  b.transmittance(shadow, tb);
  int differ = 0;
  for (size_t i = 0; i < shadow.size(); ++i) differ += std::abs(ta[i] - tb[i]) > 1e-5f;
  EXPECT_LE(differ, static_cast<int>(shadow.size()) / 2000) << "of " << shadow.size();  // rays grazing an edge
  return ties;
}

TEST(RayTracerInstances, ASharedMeshIsBuiltOnce) {
  const Scene s = instanced_scene(ball(), 25, kLight);
  const RayTracer tracer(s);
  EXPECT_EQ(tracer.geometry_count(), 2u);  // the ground and the ball
  EXPECT_EQ(tracer.instance_count(), 25u);
  EXPECT_EQ(tracer.stored_triangle_count(), s.objects[0].mesh.triangle_count() + s.objects[1].shared_mesh->triangle_count());
  EXPECT_EQ(tracer.triangle_count(), s.triangle_count());
  const RayTracer flat(unshared(s));
  EXPECT_EQ(flat.geometry_count(), 26u);
  EXPECT_EQ(flat.instance_count(), 0u);
  EXPECT_EQ(flat.stored_triangle_count(), s.triangle_count());
  // Embree holds the ball once: its memory is a fraction of 25 copies'.
  EXPECT_GT(tracer.memory_bytes(), 0u);
  EXPECT_LT(tracer.memory_bytes() * 5, flat.memory_bytes());
  // A mesh placed once (shared_mesh set, one user) stays in the top level.
  const RayTracer one(instanced_scene(ball(), 1, kLight));
  EXPECT_EQ(one.instance_count(), 0u);
  EXPECT_EQ(one.geometry_count(), 2u);
}

TEST(RayTracerInstances, HitsThroughInstancesEqualTheUnsharedScene) {
  const Scene s = instanced_scene(ball(), 25, kLight);
  const RayTracer instanced(s), flat(unshared(s));
  ASSERT_EQ(instanced.instance_count(), 25u);
  const std::vector<Ray> rays = random_rays(20000, 5);
  EXPECT_LT(expect_same_hits(instanced, flat, rays, s), 20);
}

TEST(RayTracerInstances, PerObjectMaterialsThroughOneSharedMesh) {
  // A leaf card carrying an alpha ramp (2 x 1 texels, alpha 0 and 1: a bilinear ramp along u),
  // placed four times: masked, blended, half transparent without texture, opaque.
  auto card = std::make_shared<TriangleMesh>(testing::quad_y(0.0f, -0.5f, 0.5f, -0.5f, 0.5f));
  card->uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  auto ramp = std::make_shared<const Texture>(2, 1, std::vector<float>{1, 1, 1, 0, 1, 1, 1, 1}, true, "ramp");
  std::vector<SceneObject> cards;
  for (int i = 0; i < 4; ++i) {
    SceneObject o = testing::object(TriangleMesh{});
    o.shared_mesh = card;
    if (i == 0) o.material.alpha = SurfaceAlpha{ramp, AlphaMode::Mask, 0.5f};
    if (i == 1) o.material.alpha = SurfaceAlpha{ramp, AlphaMode::Blend, 0.5f};
    if (i == 2) o.material.opacity = 0.25f;
    ObjectTransform t;
    t.translate = {-1.5f + 1.0f * i, 1.0f, 0.0f};
    t.rotate = {0, i == 1 ? 180.0f : 0.0f, 0};  // turned: u runs along -x
    t.scale = i == 0 ? Vec3f(-1, 1, 1) : Vec3f(1);  // mirrored: u runs along -x
    place_object(o, t);
    cards.push_back(std::move(o));
  }
  const Scene s = testing::ground_scene(std::move(cards), kLight);
  const RayTracer instanced(s), flat(unshared(s));
  ASSERT_EQ(instanced.instance_count(), 4u);
  EXPECT_TRUE(instanced.has_transparency());
  for (int i = 0; i < 4; ++i)
    for (float dx : {-0.4f, -0.15f, 0.05f, 0.3f, 0.45f}) {
      SCOPED_TRACE(::testing::Message() << "card " << i << " dx " << dx);
      const float x = -1.5f + 1.0f * i + dx;
      // u of the card at world x: mirrored and turned cards run u along -x.
      const float u = (i <= 1 ? -dx : dx) + 0.5f;
      const float alpha = u < 0.25f ? 1 - (u + 0.25f) / 0.5f : u <= 0.75f ? (u - 0.25f) / 0.5f : 1 - (u - 0.75f) / 0.5f;
      const float expected = i == 0 ? (alpha >= 0.5f ? 0.0f : 1.0f) : i == 1 ? 1.0f - alpha : i == 2 ? 0.75f : 0.0f;
      const ShadowRay r = shadow_ray_to({x, 0, 0.2f}, {0, 1, 0}, {x, 2.4f, 0.2f});
      EXPECT_NEAR(instanced.transmittance(r), expected, 1e-4f);
      EXPECT_NEAR(instanced.transmittance(r), flat.transmittance(r), 1e-5f);
      // A camera ray from above passes a mask's hole (and a blend below its cutoff) to the ground.
      Ray down;
      down.org = {x, 3, 0.2f};
      down.dir = {0, -1, 0};
      Hit hit, hit_flat;
      ASSERT_TRUE(instanced.intersect(down, &hit));
      ASSERT_TRUE(flat.intersect(down, &hit_flat));
      const bool seen = i >= 2 || alpha >= 0.5f;
      EXPECT_EQ(hit.object, seen ? 1u + i : 0u);
      EXPECT_EQ(hit.object, hit_flat.object);
      EXPECT_EQ(hit.prim, hit_flat.prim);
    }
}

TEST(RayTracerInstances, AMovedInstanceTakesItsNewTransform) {
  const Scene base = instanced_scene(ball(), 12, kLight);
  for (bool movable : {false, true}) {
    SCOPED_TRACE(movable ? "built movable" : "not built movable");
    Scene current = base;
    const std::vector<uint32_t> moving = {3, 8};
    RayTracer tracer(current, movable ? std::span<const uint32_t>(moving) : std::span<const uint32_t>());
    int ties = 0;
    for (int k = 1; k <= 3; ++k) {
      SCOPED_TRACE(k);
      for (uint32_t o : moving) {
        ObjectTransform t = testing::grid_placement(static_cast<int>(o));
        t.translate = t.translate + Vec3f(0.2f * k, 0.1f * k, -0.15f * k);
        t.rotate.y += 25.0f * k;
        if (k == 2) t.scale.x = -t.scale.x;  // starts mirroring
        SceneObject& obj = current.objects[o];
        obj.placement = Mat4::identity();
        place_object(obj, t);
      }
      tracer.update_objects(current, moving);
      EXPECT_EQ(tracer.refits(), k);
      EXPECT_EQ(tracer.rebuilds(), 0);
      const RayTracer fresh(unshared(current));
      ties += expect_same_hits(tracer, fresh, random_rays(4000, 100 + k), current);
    }
    EXPECT_LT(ties, 10);
    // An object that no longer places its shared mesh (its mesh edited: unshared) rebuilds.
    current.objects[3].unshare();
    current.objects[3].mesh.positions[0] = current.objects[3].mesh.positions[0] + Vec3f(0, 0.01f, 0);
    const std::vector<uint32_t> edited = {3};
    tracer.update_objects(current, edited);
    EXPECT_EQ(tracer.rebuilds(), 1);
    EXPECT_EQ(tracer.instance_count(), 11u);
    expect_same_hits(tracer, RayTracer(unshared(current)), random_rays(2000, 7), current);
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
