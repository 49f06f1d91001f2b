#include "penumbra/raster/raster_triangle.h"

#include "penumbra/scene/scene.h"

namespace penumbra {

void append_raster_triangles(const TriangleMesh& mesh, float material_opacity, uint32_t object,
                             std::vector<RasterTriangle>* out) {
  size_t n = mesh.triangle_count();
  bool per_triangle = mesh.triangle_opacity.size() == n && n > 0;
  out->reserve(out->size() + n);
  for (size_t i = 0; i < n; ++i) {
    RasterTriangle t;
    for (int k = 0; k < 3; ++k) t.p[k] = mesh.vertex(i, k);
    t.opacity = material_opacity * (per_triangle ? mesh.triangle_opacity[i] : 1.0f);
    t.object = object;
    t.prim = static_cast<uint32_t>(i);
    out->push_back(t);
  }
}

std::vector<RasterTriangle> gather_raster_triangles(const Scene& scene) {
  std::vector<RasterTriangle> out;
  size_t total = 0;
  for (const SceneObject& o : scene.objects) total += o.mesh.triangle_count();
  out.reserve(total);
  for (size_t i = 0; i < scene.objects.size(); ++i)
    append_raster_triangles(scene.objects[i].mesh, scene.objects[i].material.opacity,
                            static_cast<uint32_t>(i), &out);
  return out;
}

}  // namespace penumbra
