// The rasterizer's input: world-space triangles with the opacity they cast with and where
// they came from, gathered once from a Scene so a method can rasterize the whole scene from
// one light with one call. Outputs name a triangle by its index in this list.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/scene/mesh.h"

namespace penumbra {

struct Scene;

struct RasterTriangle {
  Vec3f p[3];
  // Material::opacity times TriangleMesh::triangle_opacity[prim] (1 = opaque).
  float opacity = 1.0f;
  uint32_t object = 0;  // index into Scene::objects
  uint32_t prim = 0;    // triangle within that object's mesh
};

// Appends the triangles of one mesh (opacity = material_opacity times the per-triangle
// opacity when the mesh has one).
void append_raster_triangles(const TriangleMesh& mesh, float material_opacity, uint32_t object,
                             std::vector<RasterTriangle>* out);
// Every triangle of every object of the scene, in object order then mesh order.
std::vector<RasterTriangle> gather_raster_triangles(const Scene& scene);
// What gather_raster_triangles returns for a scene of `triangles` triangles.
inline uint64_t raster_triangles_bytes(uint64_t triangles) { return triangles * sizeof(RasterTriangle); }

}  // namespace penumbra
