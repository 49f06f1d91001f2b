#include "penumbra/raster/raster_triangle.h"

#include "penumbra/scene/scene.h"

namespace penumbra {

namespace {
void append(const TriangleMesh& mesh, float material_opacity, const SurfaceAlpha* alpha, uint32_t object,
            std::vector<RasterTriangle>* out) {
  size_t n = mesh.triangle_count();
  bool per_triangle = mesh.triangle_opacity.size() == n && n > 0;
  if (alpha && !(alpha->active() && mesh.uvs.size() == mesh.positions.size())) alpha = nullptr;
  out->reserve(out->size() + n);
  for (size_t i = 0; i < n; ++i) {
    RasterTriangle t;
    for (int k = 0; k < 3; ++k) t.p[k] = mesh.vertex(i, k);
    t.opacity = material_opacity * (per_triangle ? mesh.triangle_opacity[i] : 1.0f);
    t.object = object;
    t.prim = static_cast<uint32_t>(i);
    if (alpha) {
      t.alpha = alpha;
      for (int k = 0; k < 3; ++k) t.uv[k] = mesh.uvs[mesh.indices[3 * i + k]];
    }
    out->push_back(t);
  }
}
}  // namespace

void append_raster_triangles(const TriangleMesh& mesh, const Material& material, uint32_t object,
                             std::vector<RasterTriangle>* out) {
  append(mesh, material.opacity, &material.alpha, object, out);
}

void append_raster_triangles(const TriangleMesh& mesh, float material_opacity, uint32_t object,
                             std::vector<RasterTriangle>* out) {
  append(mesh, material_opacity, nullptr, object, out);
}

std::vector<RasterTriangle> gather_raster_triangles(const Scene& scene) {
  std::vector<RasterTriangle> out;
  size_t total = 0;
  for (const SceneObject& o : scene.objects) total += o.mesh.triangle_count();
  out.reserve(total);
  for (size_t i = 0; i < scene.objects.size(); ++i)
    append_raster_triangles(scene.objects[i].mesh, scene.objects[i].material, static_cast<uint32_t>(i), &out);
  return out;
}

}  // namespace penumbra
