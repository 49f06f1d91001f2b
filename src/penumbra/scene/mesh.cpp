#include "penumbra/scene/mesh.h"

#include <cmath>
#include <cstring>
#include <unordered_map>
#include <utility>

namespace penumbra {

Bounds3f TriangleMesh::bounds() const {
  Bounds3f b;
  for (Vec3f p : positions) b.extend(p);
  return b;
}

void TriangleMesh::transform(const Mat4& m) {
  for (Vec3f& p : positions) p = m.transform_point(p);
  if (!normals.empty()) {
    // Normals transform by the inverse transpose, so they stay perpendicular to the
    // surface under non-uniform scale (pbrt-v4 §3.10.3).
    Mat4 nm = m.inverse().transposed();
    for (Vec3f& n : normals) {
      Vec3f t = nm.transform_vector(n);
      float len = length(t);
      n = len > 0 ? t / len : n;
    }
  }
  // A mirroring transform (negative determinant) turns counter-clockwise windings
  // clockwise; swapping two indices per triangle keeps the geometric normals facing the
  // same side as the (inverse-transpose) shading normals, i.e. outward for closed meshes.
  const auto& a = m.m;
  float det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
              a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
              a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  if (det < 0)
    for (size_t t = 0; t + 2 < indices.size(); t += 3) std::swap(indices[t + 1], indices[t + 2]);
}

Mat4 ObjectTransform::matrix() const {
  return Mat4::translate(translate) * Mat4::rotate_z(rotate.z) * Mat4::rotate_y(rotate.y) * Mat4::rotate_x(rotate.x) *
         Mat4::scale(scale);
}

bool SceneObject::semi_transparent() const {
  if (material.semi_transparent()) return true;
  for (float a : mesh.triangle_opacity)
    if (a < 1.0f) return true;
  return false;
}

bool ObjectTransform::similarity() const {
  float ax = std::abs(scale.x);
  return std::abs(std::abs(scale.y) - ax) <= 1e-6f * ax && std::abs(std::abs(scale.z) - ax) <= 1e-6f * ax;
}

namespace {
bool is_identity(const Mat4& a) {
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      if (a.m[r][c] != (r == c ? 1.0f : 0.0f)) return false;
  return true;
}
}  // namespace

void place_object(SceneObject& object, const ObjectTransform& t) {
  // A shared object placed already (a generator's) stays as it is under the identity (a scene
  // file's generator entry without a transform), rather than computing the same mesh again.
  if (object.shared_mesh && t == ObjectTransform{} && !is_identity(object.placement)) return;
  const Mat4 m = t.matrix();
  if (object.shared_mesh) {
    // One transform by the whole placement (the first one exactly t.matrix(), as for an
    // object of its own), so that mesh == *shared_mesh transformed by placement, bit for bit.
    object.placement = is_identity(object.placement) ? m : m * object.placement;
    object.mesh = *object.shared_mesh;
    object.mesh.transform(object.placement);
  } else {
    object.mesh.transform(m);
  }
  if (object.sphere && t.similarity())
    object.sphere = SphereShape{m.transform_point(object.sphere->center), object.sphere->radius * std::abs(t.scale.x)};
  else
    object.sphere.reset();
}

void place_object(SceneObject& placed, const SceneObject& unplaced, const ObjectTransform& t) {
  placed.shared_mesh = unplaced.shared_mesh;
  placed.placement = unplaced.placement;
  // A shared object's mesh is computed from its shared mesh: no copy of the unplaced one.
  if (!placed.shared_mesh) placed.mesh = unplaced.mesh;
  placed.sphere = unplaced.sphere;
  place_object(placed, t);
}

void unshare_single_placements(std::vector<SceneObject>& objects) {
  std::unordered_map<const TriangleMesh*, int> users;
  for (const SceneObject& o : objects)
    if (o.shared_mesh) ++users[o.shared_mesh.get()];
  for (SceneObject& o : objects)
    if (o.shared_mesh && users[o.shared_mesh.get()] < 2) o.unshare();
}

void TriangleMesh::append(const TriangleMesh& other) {
  const size_t base = positions.size();
  const bool was_empty = positions.empty();
  const size_t tris_before = triangle_count();
  // Vertex normals survive only if both sides have them; mixing smooth and flat parts
  // would leave vertices without a normal, so the merged mesh falls back to flat shading.
  const bool keep_normals = (was_empty || !normals.empty()) && !other.normals.empty();
  positions.insert(positions.end(), other.positions.begin(), other.positions.end());
  if (keep_normals)
    normals.insert(normals.end(), other.normals.begin(), other.normals.end());
  else
    normals.clear();
  // Texture coordinates, like normals, survive only if both sides have them.
  const bool keep_uvs = (was_empty || !uvs.empty()) && !other.uvs.empty();
  if (keep_uvs)
    uvs.insert(uvs.end(), other.uvs.begin(), other.uvs.end());
  else
    uvs.clear();
  for (uint32_t i : other.indices) indices.push_back(static_cast<uint32_t>(base + i));
  // Per-triangle opacity: a side without it is opaque (1).
  if (!triangle_opacity.empty() || !other.triangle_opacity.empty()) {
    triangle_opacity.resize(tris_before, 1.0f);
    if (other.triangle_opacity.empty())
      triangle_opacity.resize(triangle_count(), 1.0f);
    else
      triangle_opacity.insert(triangle_opacity.end(), other.triangle_opacity.begin(),
                              other.triangle_opacity.end());
  }
}

bool TriangleMesh::is_closed() const {
  if (indices.empty()) return false;
  // Vertices are welded by exact position first: importers and shading seams split a
  // vertex into copies with different normals, which does not open the surface.
  auto key_of = [](Vec3f p) {
    uint32_t b[3];
    std::memcpy(b, &p, sizeof b);
    return std::make_pair(static_cast<uint64_t>(b[0]) << 32 | b[1], b[2]);
  };
  struct KeyHash {
    size_t operator()(const std::pair<uint64_t, uint32_t>& k) const {
      return std::hash<uint64_t>()(k.first * 0x9e3779b97f4a7c15ULL ^ k.second);
    }
  };
  std::unordered_map<std::pair<uint64_t, uint32_t>, uint32_t, KeyHash> weld;
  weld.reserve(positions.size());
  std::vector<uint32_t> canon(positions.size());
  for (size_t i = 0; i < positions.size(); ++i) {
    Vec3f p = positions[i] + Vec3f(0.0f);  // -0 and +0 weld together
    canon[i] = weld.emplace(key_of(p), static_cast<uint32_t>(weld.size())).first->second;
  }
  // Each directed edge a->b must occur exactly once, and so must b->a: then every edge
  // has exactly two triangles and they traverse it in opposite directions (consistent
  // orientation).
  std::unordered_map<uint64_t, int> directed;
  directed.reserve(indices.size());
  for (size_t t = 0; t + 2 < indices.size(); t += 3) {
    uint32_t v[3] = {canon[indices[t]], canon[indices[t + 1]], canon[indices[t + 2]]};
    if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) continue;  // degenerate: no area
    for (int k = 0; k < 3; ++k) {
      uint64_t e = static_cast<uint64_t>(v[k]) << 32 | v[(k + 1) % 3];
      if (++directed[e] > 1) return false;
    }
  }
  if (directed.empty()) return false;
  for (const auto& [e, count] : directed) {
    uint64_t reverse = (e << 32) | (e >> 32);
    if (!directed.count(reverse)) return false;
  }
  return true;
}

}  // namespace penumbra
