// The rasterizer's input: world-space triangles with the opacity they cast with and where
// they came from, gathered once from a Scene so a method can rasterize the whole scene from
// one light with one call. Outputs name a triangle by its index in this list.
//
// A triangle is 48 bytes. What an alpha-textured one needs besides (its alpha texture and
// its corners' texture coordinates, issue 20) lives in a side table, TriangleTextures, looked
// up by the triangle's object and prim, so untextured scenes pay nothing for textures (issue
// 33). RasterTriangles holds a list and its table; RasterTriangleView, what the rasterizers
// take, points at both.
#pragma once

#include <cstdint>
#include <span>
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

  // Where the line origin + s dir meets the triangle's plane: its barycentrics (b1, b2) and s
  // (Moller-Trumbore's solution; inside the triangle iff b1, b2 >= 0 and b1 + b2 <= 1). False
  // when the line is parallel to the plane.
  bool line_crossing(Vec3f origin, Vec3f dir, float* b1, float* b2, float* s) const {
    return shader::triangle_line_crossing(p[0], p[1], p[2], origin, dir, *b1, *b2, *s);
  }
};
static_assert(sizeof(RasterTriangle) == 48, "RasterTriangle stays 48 bytes: textures live in TriangleTextures");

// Lines from one origin through one triangle, set up once (the edges and the origin's terms of
// Moller-Trumbore), for many directions: afsm's light samples seen from one view sample
// through one caster. crossing() equals RasterTriangle::line_crossing bit for bit.
struct TriangleLines {
  shader::TriangleLineSetup setup;
  TriangleLines(const RasterTriangle& t, Vec3f origin) : setup(shader::triangle_line_setup(t.p[0], t.p[1], t.p[2], origin)) {}
  bool crossing(Vec3f dir, float* b1, float* b2, float* s) const {
    return shader::triangle_line_setup_crossing(setup, dir, *b1, *b2, *s);
  }
};

// The texture side table of a triangle list: per object, its alpha texture (SurfaceAlpha, which
// holds the image) and its triangles' corner texture coordinates, for the objects that have
// one (an active alpha mode and texture coordinates on the mesh). Copies, so it stays valid
// whatever happens to the scene's meshes.
class TriangleTextures {
 public:
  // Records object `object`'s alpha texture, when its material has one and its mesh has
  // texture coordinates (the scene loader checks that a textured mesh has them).
  void add(const TriangleMesh& mesh, const Material& material, uint32_t object);
  // Every object of the scene.
  static TriangleTextures of(const Scene& scene);

  bool empty() const { return textured_objects_ == 0; }
  // The triangle's alpha texture, null when its opacity is the same all over it.
  const SurfaceAlpha* alpha(const RasterTriangle& t) const {
    return t.object < objects_.size() && objects_[t.object].alpha.active() ? &objects_[t.object].alpha : nullptr;
  }
  bool textured(const RasterTriangle& t) const { return alpha(t) != nullptr; }
  // The triangle may stop only part of the light somewhere (a map of opaque casters skips it).
  bool semi_transparent(const RasterTriangle& t) const {
    const SurfaceAlpha* a = alpha(t);
    return t.opacity < 1.0f || (a && a->mode == AlphaMode::Blend);
  }
  // Texture coordinates at barycentric (b1, b2) of a textured triangle.
  Vec2f uv_at(const RasterTriangle& t, float b1, float b2) const {
    return interpolate_uv(&objects_[t.object].corner_uvs[3 * static_cast<size_t>(t.prim)], b1, b2);
  }
  // The opacity at barycentric (b1, b2): the triangle's, times its alpha texture's there.
  float opacity_at(const RasterTriangle& t, float b1, float b2) const {
    const SurfaceAlpha* a = alpha(t);
    return a ? t.opacity * a->opacity(uv_at(t, b1, b2)) : t.opacity;
  }
  // The opacity where the line origin + s dir meets the triangle's plane (rasterizers: the
  // ray through a covered texel centre; the point is inside the triangle up to rounding).
  float opacity_on_line(const RasterTriangle& t, Vec3f origin, Vec3f dir) const {
    const SurfaceAlpha* a = alpha(t);
    if (!a) return t.opacity;
    float b1, b2, s;
    if (!t.line_crossing(origin, dir, &b1, &b2, &s)) return opacity_at(t, 0, 0);  // edge-on: no area
    return opacity_at(t, b1, b2);
  }
  // The same for lines from one origin set up once (TriangleLines of t).
  float opacity_on_line(const RasterTriangle& t, const TriangleLines& lines, Vec3f dir) const {
    float b1, b2, s;
    if (!lines.crossing(dir, &b1, &b2, &s)) return opacity_at(t, 0, 0);
    return opacity_at(t, b1, b2);
  }
  // The opacity where the segment from origin to origin + dir crosses the triangle (0 where it
  // misses it): what a shadow ray to one light sample meets.
  float opacity_on_segment(const RasterTriangle& t, Vec3f origin, Vec3f dir) const {
    float b1, b2, s;
    if (!t.line_crossing(origin, dir, &b1, &b2, &s) || !(b1 >= 0 && b2 >= 0 && b1 + b2 <= 1 && s > 0 && s < 1))
      return 0.0f;
    return opacity_at(t, b1, b2);
  }
  size_t memory_bytes() const;
  // What of(scene) holds for a scene of `objects` objects and `triangles` triangles, all of them
  // textured (for memory estimates).
  static uint64_t bytes(uint64_t objects, uint64_t triangles);

 private:
  struct Entry {
    SurfaceAlpha alpha;  // inactive: the object is not textured
    std::vector<Vec2f> corner_uvs;  // 3 per triangle (TriangleMesh::corner_uvs)
  };
  std::vector<Entry> objects_;  // by object index, up to the last textured object
  size_t textured_objects_ = 0;
};

// A triangle list and its texture side table.
struct RasterTriangles {
  std::vector<RasterTriangle> list;
  TriangleTextures textures;
  size_t size() const { return list.size(); }
  const RasterTriangle& operator[](size_t i) const { return list[i]; }
};

// What the rasterizers take: a span of triangles and the side table of their textures (null:
// none textured). Made from a RasterTriangles (with its textures) or from a bare list.
struct RasterTriangleView {
  std::span<const RasterTriangle> list;
  const TriangleTextures* textures = nullptr;

  RasterTriangleView() = default;  // no triangles
  RasterTriangleView(const RasterTriangles& t) : list(t.list), textures(&t.textures) {}  // NOLINT: implicit
  RasterTriangleView(std::span<const RasterTriangle> l, const TriangleTextures* x = nullptr)  // NOLINT: implicit
      : list(l), textures(x) {}
  RasterTriangleView(const std::vector<RasterTriangle>& l, const TriangleTextures* x = nullptr)  // NOLINT: implicit
      : list(l), textures(x) {}

  size_t size() const { return list.size(); }
  bool empty() const { return list.empty(); }
  const RasterTriangle& operator[](size_t i) const { return list[i]; }
  auto begin() const { return list.begin(); }
  auto end() const { return list.end(); }
  bool textured(const RasterTriangle& t) const { return textures && textures->textured(t); }
  bool semi_transparent(const RasterTriangle& t) const {
    return textures ? textures->semi_transparent(t) : t.opacity < 1.0f;
  }
  float opacity_on_line(const RasterTriangle& t, Vec3f origin, Vec3f dir) const {
    return textures ? textures->opacity_on_line(t, origin, dir) : t.opacity;
  }
};

// Appends the triangles of one mesh: opacity = the material's times the per-triangle opacity
// when the mesh has one.
void append_raster_triangles(const TriangleMesh& mesh, float material_opacity, uint32_t object,
                             std::vector<RasterTriangle>* out);
// The same with the material's alpha texture recorded in out->textures.
void append_raster_triangles(const TriangleMesh& mesh, const Material& material, uint32_t object, RasterTriangles* out);
// Every triangle of every object of the scene, in object order then mesh order, with the
// objects' alpha textures.
RasterTriangles gather_raster_triangles(const Scene& scene);
// What gather_raster_triangles' list takes for a scene of `triangles` triangles (the side
// table: TriangleTextures::bytes).
inline uint64_t raster_triangles_bytes(uint64_t triangles) { return triangles * sizeof(RasterTriangle); }

}  // namespace penumbra
