#include "penumbra/raster/raster_triangle.h"

#include "penumbra/scene/scene.h"

namespace penumbra {

void TriangleTextures::add(const TriangleMesh& mesh, const Material& material, uint32_t object) {
  if (!material.alpha.active() || mesh.uvs.size() != mesh.positions.size() || mesh.triangle_count() == 0) return;
  if (objects_.size() <= object) objects_.resize(object + 1);
  Entry& e = objects_[object];
  if (!e.alpha.active()) ++textured_objects_;
  e.alpha = material.alpha;
  e.corner_uvs = mesh.corner_uvs();
}

TriangleTextures TriangleTextures::of(const Scene& scene) {
  TriangleTextures t;
  for (size_t i = 0; i < scene.objects.size(); ++i)
    t.add(scene.objects[i].mesh, scene.objects[i].material, static_cast<uint32_t>(i));
  return t;
}

size_t TriangleTextures::memory_bytes() const {
  size_t bytes = objects_.capacity() * sizeof(Entry);
  for (const Entry& e : objects_) bytes += e.corner_uvs.capacity() * sizeof(Vec2f);
  return bytes;
}

uint64_t TriangleTextures::bytes(uint64_t objects, uint64_t triangles) {
  return objects * sizeof(Entry) + 3 * triangles * sizeof(Vec2f);
}

void append_raster_triangles(const TriangleMesh& mesh, float material_opacity, uint32_t object,
                             std::vector<RasterTriangle>* out) {
  const size_t n = mesh.triangle_count();
  const bool per_triangle = mesh.triangle_opacity.size() == n && n > 0;
  // Callers append object after object: an exact reserve per call would copy the whole list
  // each time (quadratic in the objects; occlusion-textures' slicing of the 51-object forest
  // spent most of its time in page faults). Let push_back grow it geometrically instead.
  for (size_t i = 0; i < n; ++i) {
    RasterTriangle t;
    for (int k = 0; k < 3; ++k) t.p[k] = mesh.vertex(i, k);
    t.opacity = material_opacity * (per_triangle ? mesh.triangle_opacity[i] : 1.0f);
    t.object = object;
    t.prim = static_cast<uint32_t>(i);
    out->push_back(t);
  }
}

void append_raster_triangles(const TriangleMesh& mesh, const Material& material, uint32_t object, RasterTriangles* out) {
  append_raster_triangles(mesh, material.opacity, object, &out->list);
  out->textures.add(mesh, material, object);
}

RasterTriangles gather_raster_triangles(const Scene& scene) {
  RasterTriangles out;
  size_t total = 0;
  for (const SceneObject& o : scene.objects) total += o.mesh.triangle_count();
  out.list.reserve(total);
  for (size_t i = 0; i < scene.objects.size(); ++i)
    append_raster_triangles(scene.objects[i].mesh, scene.objects[i].material, static_cast<uint32_t>(i), &out);
  return out;
}

}  // namespace penumbra
