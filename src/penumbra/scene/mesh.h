// Triangle meshes in world space, with the material they carry.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/core/math.h"

namespace penumbra {

struct Material {
  Vec3f albedo{0.8f, 0.8f, 0.8f};
  // 1 = opaque; below 1 the surface is a semi-transparent caster: a shadow ray crossing
  // it keeps (1 - opacity) of its light (xie2007 §5, deep shadow maps).
  float opacity = 1.0f;
  // One-sided surfaces are black when seen from behind (as in Mitsuba's diffuse BSDF);
  // every surface casts shadows from both sides.
  bool two_sided = true;
};

struct TriangleMesh {
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;     // per vertex, optional (empty: flat shading)
  std::vector<uint32_t> indices;  // 3 per triangle
  // Optional per-triangle opacity, multiplied with the material's (furball strands).
  std::vector<float> triangle_opacity;

  size_t triangle_count() const { return indices.size() / 3; }
  Vec3f vertex(size_t tri, int k) const { return positions[indices[3 * tri + k]]; }
  Bounds3f bounds() const;
  // Applies an affine transform to positions (and the inverse transpose to normals).
  // A mirroring transform (negative determinant) also swaps two indices per triangle, so
  // windings keep facing the same side as the normals (outward for closed meshes).
  void transform(const Mat4& m);
  // Appends another mesh (indices offset). Normals are kept only if both meshes have them
  // (or this one is empty); per-triangle opacity is filled with 1 where a side lacks it.
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
  TriangleMesh mesh;
  Material material;
  bool closed = false;  // mesh.is_closed(), computed once at load
  std::optional<SphereShape> sphere;
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
// sphere, which stays one only under a similarity (dropped otherwise).
void place_object(SceneObject& object, const ObjectTransform& t);

}  // namespace penumbra
