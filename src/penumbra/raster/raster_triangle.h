// The rasterizer's input: world-space triangles with the opacity they cast with and where
// they came from, gathered once from a Scene so a method can rasterize the whole scene from
// one light with one call. Outputs name a triangle by its index in this list.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/raster/raster_shared.h"
#include "penumbra/scene/mesh.h"

namespace penumbra {

struct Scene;

struct RasterTriangle {
  Vec3f p[3];
  // Material::opacity times TriangleMesh::triangle_opacity[prim] (1 = opaque).
  float opacity = 1.0f;
  uint32_t object = 0;  // index into Scene::objects
  uint32_t prim = 0;    // triangle within that object's mesh
  // An alpha texture (issue 20): the material's (it outlives the triangle list, as the scene
  // does), null when the triangle's opacity is the same all over it; then the texture
  // coordinates of the three corners.
  const SurfaceAlpha* alpha = nullptr;
  Vec2f uv[3];

  // The triangle may stop only part of the light somewhere (a map of opaque casters skips it).
  bool semi_transparent() const { return opacity < 1.0f || (alpha && alpha->mode == AlphaMode::Blend); }
  // The opacity where the line origin + s dir meets the triangle's plane (rasterizers: the
  // ray through a covered texel centre; the point is inside the triangle up to rounding).
  float opacity_on_line(Vec3f origin, Vec3f dir) const {
    if (!alpha) return opacity;
    float b1, b2, s;
    if (!line_crossing(origin, dir, &b1, &b2, &s)) return opacity * alpha->opacity(uv[0]);  // edge-on: no area
    return opacity * alpha->opacity(uv_at(b1, b2));
  }
  // Where the line origin + s dir meets the triangle's plane: its barycentrics (b1, b2) and s
  // (Moller-Trumbore's solution; inside the triangle iff b1, b2 >= 0 and b1 + b2 <= 1). False
  // when the line is parallel to the plane.
  bool line_crossing(Vec3f origin, Vec3f dir, float* b1, float* b2, float* s) const {
    return shader::triangle_line_crossing(p[0], p[1], p[2], origin, dir, *b1, *b2, *s);
  }
  // The opacity where the segment from origin to origin + dir crosses the triangle (0 where it
  // misses it): what a shadow ray to one light sample meets.
  float opacity_on_segment(Vec3f origin, Vec3f dir) const {
    float b1, b2, s;
    if (!line_crossing(origin, dir, &b1, &b2, &s) || !(b1 >= 0 && b2 >= 0 && b1 + b2 <= 1 && s > 0 && s < 1))
      return 0.0f;
    return alpha ? opacity * alpha->opacity(uv_at(b1, b2)) : opacity;
  }
  // Texture coordinates at barycentric (b1, b2) (P = (1-b1-b2) p0 + b1 p1 + b2 p2).
  Vec2f uv_at(float b1, float b2) const {
    const float b0 = 1.0f - b1 - b2;
    return {b0 * uv[0].x + b1 * uv[1].x + b2 * uv[2].x, b0 * uv[0].y + b1 * uv[1].y + b2 * uv[2].y};
  }
};

// Appends the triangles of one mesh: opacity = the material's times the per-triangle opacity
// when the mesh has one, and the material's alpha texture where it has one (the mesh then has
// texture coordinates: the scene loader checks).
void append_raster_triangles(const TriangleMesh& mesh, const Material& material, uint32_t object,
                             std::vector<RasterTriangle>* out);
// The same for a mesh of one opacity and no alpha texture.
void append_raster_triangles(const TriangleMesh& mesh, float material_opacity, uint32_t object,
                             std::vector<RasterTriangle>* out);
// Every triangle of every object of the scene, in object order then mesh order.
std::vector<RasterTriangle> gather_raster_triangles(const Scene& scene);
// What gather_raster_triangles returns for a scene of `triangles` triangles.
inline uint64_t raster_triangles_bytes(uint64_t triangles) { return triangles * sizeof(RasterTriangle); }

}  // namespace penumbra
