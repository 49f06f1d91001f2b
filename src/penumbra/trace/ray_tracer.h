// The geometry ray tracer on Embree 3: one BVH over every object of a scene, closest-hit
// queries for the camera pass and batched shadow rays with transmittance through
// semi-transparent casters.
#pragma once

#include <cstdint>
#include <memory>
#include <span>

#include "penumbra/core/math.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

struct Ray {
  Vec3f org;
  Vec3f dir;
  float tnear = 0;
  float tfar = kInfinity;
};

struct Hit {
  static constexpr uint32_t kMiss = 0xFFFFFFFFu;  // `object` of a ray that hit nothing
  float t = kInfinity;
  uint32_t object = 0;  // index into Scene::objects
  uint32_t prim = 0;    // triangle within the object's mesh
  float u = 0, v = 0;   // barycentrics of vertices 1 and 2
  Vec3f ng;             // unnormalised geometric normal (winding order)
};

// A shadow ray's transmittance at or below this counts as 0: the ray is blocked and stops
// (the transparency filter multiplies (1 - opacity) in per crossing).
inline constexpr float kOpaqueCutoff = 1e-4f;

// A shadow segment from org along unit dir up to tfar.
struct ShadowRay {
  Vec3f org;
  float tnear = 0;
  Vec3f dir;
  float tfar = 0;
};

// Offsets a surface point along its geometric normal toward the side `dir` leaves into,
// by a margin relative to the point's magnitude: far enough to escape the surface's own
// triangle (no acne), close enough not to cross a touching surface (no contact leaks).
Vec3f offset_ray_origin(Vec3f p, Vec3f ng, Vec3f dir);
// A shadow ray from surface point p (geometric normal ng) to point q on a light.
ShadowRay shadow_ray_to(Vec3f p, Vec3f ng, Vec3f q);

class RayTracer {
 public:
  // Builds one BVH over every object of `scene` (Embree's single-level SAH build, the fastest
  // to trace). A shared mesh placed by several objects (SceneObject::shared_mesh) is built
  // once, as a BVH of its own, and each object placing it is an Embree instance of it in the
  // top level (a two-level scene: the objects of their own stay in the top level's BVH). Hits
  // through an instance report the object, its world triangle and world normal as the flat
  // scene would. With `movable` objects (the parts of an animated scene's object tracks,
  // SequenceRenderer), a two-level build instead: one BVH per object under a top level, the
  // movable objects' BVHs refittable (update_objects), so moving them costs a refit of their
  // BVHs and a rebuild of the top level over the objects, not a rebuild of the scene.
  explicit RayTracer(const Scene& scene, std::span<const uint32_t> movable = {});
  ~RayTracer();
  RayTracer(const RayTracer&) = delete;
  RayTracer& operator=(const RayTracer&) = delete;

  bool intersect(const Ray& ray, Hit* hit) const;
  // Closest hits of many rays (Embree rtcIntersect1M streams, as for shadow rays): hits[i]
  // for rays[i], object = Hit::kMiss where nothing was hit. Same hits as one at a time.
  // `coherent`: consecutive rays are close (camera rays in 4 x 4 pixel tiles), so Embree may
  // trace them as packets (measured 15-25% faster for the camera pass; shadow-ray fans from one
  // point were slower as packets, reference.md).
  void intersect(std::span<const Ray> rays, std::span<Hit> hits, bool coherent = false) const;
  // Binary occlusion for opaque geometry; semi-transparent surfaces count as occluders.
  bool occluded(const ShadowRay& ray) const;
  // Fraction of light passing along the ray: 0 if an opaque surface blocks it, else the
  // product of (1 - opacity) over the semi-transparent surfaces it crosses.
  float transmittance(const ShadowRay& ray) const;
  // Batched versions over n rays (Embree rtcOccluded1M streams: 1.5-2x faster than single
  // rays for incoherent shadow rays). out[i] in {0,1} (occluded) or [0,1] (transmittance).
  void transmittance(std::span<const ShadowRay> rays, std::span<float> out) const;
  // Transmittance of the segments from surface point p (geometric normal ng) to the points
  // p + (x[i], y[i], z[i]), i < n: a fan of shadow rays toward a light's samples. They share
  // one origin (offset as shadow_ray_to does, per ray) and need no ShadowRay set-up: the
  // rays are written straight into Embree's stream layout. The arrays need no padding.
  void transmittance_fan(Vec3f p, Vec3f ng, const float* x, const float* y, const float* z, size_t n,
                         float* out) const;

  // New vertex positions for `objects` (indices into scene.objects; the same triangles, as an
  // animated transform gives): the Embree scene follows `scene`, which must be the scene this
  // tracer serves from now on (the transparency filter reads its per-triangle opacities).
  // Objects built movable, with the vertex and triangle counts they were built with, are
  // refit; an instance that still places the shared mesh it was built with only takes its new
  // placement (SceneObject::placement) as its transform; anything else makes the whole scene
  // rebuild.
  void update_objects(const Scene& scene, std::span<const uint32_t> objects);

  bool has_transparency() const { return has_transparency_; }
  // The scene's triangles (world space, every object's), as the rays see them.
  size_t triangle_count() const { return triangle_count_; }
  // What Embree holds: the triangles in its buffers (a shared mesh once, however many objects
  // place it), its triangle geometries (one BVH each in a two-level scene: one per object of
  // its own, one per shared mesh) and its instances (one per object placing a shared mesh).
  size_t stored_triangle_count() const { return stored_triangle_count_; }
  size_t geometry_count() const { return geometry_count_; }
  size_t instance_count() const { return instance_count_; }
  // The bytes the Embree device gained by the last build (BVHs, vertex and index buffers), as
  // its memory monitor counts them; measured, so another tracer building at the same time
  // would count in it.
  size_t memory_bytes() const { return memory_bytes_; }
  double build_ms() const { return build_ms_; }
  // The above as {"build_ms", "bytes", "triangles", "stored_triangles", "geometries",
  // "instances"} (render statistics, the bench's load figures).
  nlohmann::json stats_json() const;
  // update_objects() calls that refit the movable objects' BVHs, their total time, and the
  // calls that had to rebuild the scene.
  int refits() const { return refits_; }
  double refit_ms() const { return refit_ms_; }
  int rebuilds() const { return rebuilds_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  bool has_transparency_ = false;
  size_t triangle_count_ = 0, stored_triangle_count_ = 0, geometry_count_ = 0, instance_count_ = 0, memory_bytes_ = 0;
  double build_ms_ = 0;
  int refits_ = 0, rebuilds_ = 0;
  double refit_ms_ = 0;
  void build(const Scene& scene);
};

}  // namespace penumbra
