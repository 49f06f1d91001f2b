// Triangle meshes in world space, with the material they carry.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/scene/texture.h"

namespace penumbra {

struct Material {
  Vec3f albedo{0.8f, 0.8f, 0.8f};
  // 1 = opaque; below 1 the surface is a semi-transparent caster: a shadow ray crossing
  // it keeps (1 - opacity) of its light (xie2007 §5, deep shadow maps).
  float opacity = 1.0f;
  // One-sided surfaces are black when seen from behind (as in Mitsuba's diffuse BSDF);
  // every surface casts shadows from both sides.
  bool two_sided = true;
  // Optional base-colour texture (linear RGB after decoding), multiplied with `albedo` at the
  // surface's texture coordinates (TriangleMesh::uvs).
  std::shared_ptr<const Texture> albedo_texture;
  // Alpha (issue 20): where the surface is (mask) or how much light it stops (blend), from a
  // texture looked up at the surface's texture coordinates; multiplied with `opacity`.
  SurfaceAlpha alpha;

  // The albedo at texture coordinates uv (`albedo` where there is no texture).
  Vec3f albedo_at(Vec2f uv) const { return albedo_texture ? albedo * albedo_texture->rgb(uv) : albedo; }
  // Whether the surface's opacity varies over it (needs texture coordinates to be known).
  bool alpha_textured() const { return alpha.active(); }
  // Whether a shadow ray or a light-space map may find the surface semi-transparent.
  bool semi_transparent() const { return opacity < 1.0f || (alpha.active() && alpha.mode == AlphaMode::Blend); }
};

// The texture coordinates at barycentric (b1, b2) of a triangle whose corners have coordinates
// c[0..2]: (1-b1-b2) c0 + b1 c1 + b2 c2 (Embree's hit.u, hit.v; Moller-Trumbore's b1, b2).
inline Vec2f interpolate_uv(const Vec2f* c, float b1, float b2) {
  const float b0 = 1.0f - b1 - b2;
  return {b0 * c[0].x + b1 * c[1].x + b2 * c[2].x, b0 * c[0].y + b1 * c[1].y + b2 * c[2].y};
}

struct TriangleMesh {
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;     // per vertex, optional (empty: flat shading)
  std::vector<uint32_t> indices;  // 3 per triangle
  // Optional per-triangle opacity, multiplied with the material's (furball strands).
  std::vector<float> triangle_opacity;
  // Optional per-vertex texture coordinates (empty: none; required by a textured material).
  std::vector<Vec2f> uvs;

  size_t triangle_count() const { return indices.size() / 3; }
  Vec3f vertex(size_t tri, int k) const { return positions[indices[3 * tri + k]]; }
  // Texture coordinates at barycentric (b1, b2) of triangle tri: P = (1-b1-b2) p0 + b1 p1 + b2 p2
  // (Embree's hit.u, hit.v). Only with uvs.
  Vec2f uv_at(size_t tri, float b1, float b2) const {
    const uint32_t* i = &indices[3 * tri];
    const Vec2f c[3] = {uvs[i[0]], uvs[i[1]], uvs[i[2]]};
    return interpolate_uv(c, b1, b2);
  }
  // Each triangle's three texture coordinates, in triangle order (3 per triangle). Only with uvs.
  std::vector<Vec2f> corner_uvs() const {
    std::vector<Vec2f> c(indices.size());
    for (size_t k = 0; k < indices.size(); ++k) c[k] = uvs[indices[k]];
    return c;
  }
  Bounds3f bounds() const;
  // Applies an affine transform to positions (and the inverse transpose to normals).
  // A mirroring transform (negative determinant) also swaps two indices per triangle, so
  // windings keep facing the same side as the normals (outward for closed meshes).
  void transform(const Mat4& m);
  // Appends another mesh (indices offset). Normals are kept only if both meshes have them
  // (or this one is empty); per-triangle opacity is filled with 1 where a side lacks it;
  // texture coordinates likewise survive only if both sides have them.
  void append(const TriangleMesh& other);
  // True when every edge is shared by exactly two triangles with opposite orientation:
  // a closed, consistently oriented surface (sintorn2008 §3.3 needs this). Vertices are
  // welded by exact position first (copies split by normals do not open a surface).
  bool is_closed() const;
};

// An analytic sphere, kept beside its tessellation so methods that handle spheres
// exactly (parker1998's appendix) can use it.
struct SphereShape {
  Vec3f center;
  float radius = 0;
};

struct SceneObject {
  std::string name;  // "objects[2]" or the generator/mesh name, for messages and stats
  TriangleMesh mesh;  // in world space: what every method reads
  Material material;
  bool closed = false;  // mesh.is_closed(), computed once at load
  std::optional<SphereShape> sphere;
  // Whether it may stop only part of the light somewhere: a semi-transparent or alpha-blended
  // material, or a triangle of opacity below 1.
  bool semi_transparent() const;

  // Mesh sharing (instancing): several objects placing one mesh (a mesh file named by several
  // scene-file objects, the forest generator's trees) hold the same `shared_mesh`, that mesh in
  // its own space, never changed, and each its `placement` (object-to-world). The ray tracer
  // builds a shared mesh once (one Embree BVH, an instance per object); a GPU scene can hold it
  // once likewise. Invariants, for the objects of a Scene:
  // - shared_mesh empty: the object is a mesh of its own; placement is the identity, unused.
  // - shared_mesh set: `mesh` equals a copy of *shared_mesh transformed by `placement` with
  //   TriangleMesh::transform, bit for bit (place_object keeps it so: it transforms once, by
  //   the whole placement), and at least two objects of the scene hold the pointer (the loader
  //   unshares a mesh placed once, unshare_single_placements: instancing one copy only adds a
  //   level to every ray's traversal).
  // Material, name and sphere stay per object: objects sharing a mesh may differ in them.
  // Code that changes `mesh` otherwise than by place_object must call unshare() first.
  std::shared_ptr<const TriangleMesh> shared_mesh;
  Mat4 placement;
  void unshare() {
    shared_mesh.reset();
    placement = Mat4::identity();
  }
};

// An object's placement as a scene file gives it (docs/scene-format.md, "Common keys"):
// scale, then rotate about x, y, z (degrees), then translate, M = T * Rz * Ry * Rx * S. Kept
// as its parts, not as the matrix, so an animation can key each part and rebuild the same
// matrix, bit for bit, that the loader builds from the same numbers.
struct ObjectTransform {
  Vec3f scale{1, 1, 1}, rotate{0, 0, 0}, translate{0, 0, 0};
  Mat4 matrix() const;
  // The same |scale| on all three axes: spheres stay spheres.
  bool similarity() const;
  bool operator==(const ObjectTransform&) const = default;
};

// Moves an object built in its own space to where `t` puts it: its mesh, and its analytic
// sphere, which stays one only under a similarity (dropped otherwise). A shared object
// (SceneObject::shared_mesh) is placed by t.matrix() * placement, its mesh computed afresh
// from the shared mesh by that one transform.
void place_object(SceneObject& object, const ObjectTransform& t);
// The same from the object as it was built (`unplaced`, e.g. an animation's keyed part): its
// geometry (mesh, sphere and sharing) replaces `placed`'s, then placed by `t`; the rest of
// `placed` (name, material) stays.
void place_object(SceneObject& placed, const SceneObject& unplaced, const ObjectTransform& t);
// Resets SceneObject::shared_mesh of every object that is the only one in `objects` to hold
// its shared mesh (the invariant of SceneObject: a mesh placed once is an object of its own).
void unshare_single_placements(std::vector<SceneObject>& objects);

}  // namespace penumbra
