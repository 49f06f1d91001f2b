#include "penumbra/shadow/soft_shadow_volumes/silhouette_edges.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <unordered_map>

#include "penumbra/core/parallel.h"
#include "penumbra/trace/ray_shared.h"

namespace penumbra::ssv {
namespace {

constexpr uint32_t kReversed = 0x80000000u;

// A vertex by its bits: welding by exact position.
struct VertexKey {
  uint32_t x, y, z;
  bool operator==(const VertexKey&) const = default;
};
VertexKey key_of(Vec3f p) { return {std::bit_cast<uint32_t>(p.x), std::bit_cast<uint32_t>(p.y), std::bit_cast<uint32_t>(p.z)}; }
struct VertexHash {
  size_t operator()(const VertexKey& k) const {
    uint64_t h = k.x * 0x9e3779b97f4a7c15ull;
    h ^= (h >> 29) + k.y * 0xbf58476d1ce4e5b9ull;
    h ^= (h >> 31) + k.z * 0x94d049bb133111ebull;
    return static_cast<size_t>(h ^ (h >> 32));
  }
};

// Side of `x` relative to the plane through a, b, c: the sign of det[b - a, c - a, x - a].
double side(Vec3f a, Vec3f b, Vec3f c, Vec3f x) {
  const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
  const double vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
  const double wx = x.x - a.x, wy = x.y - a.y, wz = x.z - a.z;
  return ux * (vy * wz - vz * wy) - uy * (vx * wz - vz * wx) + uz * (vx * wy - vy * wx);
}

// Whether the plane of triangle (a, b, w) cuts the light's region (or the triangle is
// degenerate). A margin of a thousandth of the region keeps it conservative under rounding.
bool plane_cuts_region(Vec3f a, Vec3f b, Vec3f w, const LightRegion& light) {
  const Vec3f n = cross(b - a, w - a);
  const float len = length(n);
  if (!(len > 0)) return true;
  const float at_centre = dot(n, light.center - a);
  // The plane's values over the region span at_centre +- reach.
  const float reach = light.planar ? light.half.x * std::abs(dot(n, light.s)) + light.half.y * std::abs(dot(n, light.t))
                                   : light.radius * len;
  return std::abs(at_centre) <= reach * 1.001f + 1e-3f * light.radius * len + 1e-6f * len;
}

// One side of an undirected edge as a triangle sees it: the edge's key (its welded end ids, low
// << 32 | high), the order it was met in (the triangles' order) and the triangle's third vertex,
// with kReversed where the triangle runs along the edge from its high id to its low one.
struct EdgeSide {
  uint64_t key;
  uint32_t seq;
  uint32_t third;
};

// One object's potential silhouettes, in the order of their keys.
std::vector<SilhouetteEdge> object_silhouettes(const SceneObject& obj, const LightRegion& light) {
  const TriangleMesh& m = obj.mesh;
  const float opacity = obj.material.opacity;
  // Welded ids by position, in the order the kept triangles' corners meet them; looked up once
  // per mesh vertex (a mesh's own sharing), not per corner.
  constexpr uint32_t kUnset = 0xFFFFFFFFu;
  std::vector<uint32_t> weld(m.positions.size(), kUnset);
  std::unordered_map<VertexKey, uint32_t, VertexHash> ids;
  ids.reserve(m.positions.size());
  std::vector<Vec3f> points;
  auto id_of = [&](uint32_t vi) {
    if (weld[vi] == kUnset) {
      const Vec3f p = m.positions[vi];
      auto [it, inserted] = ids.emplace(key_of(p), static_cast<uint32_t>(points.size()));
      if (inserted) points.push_back(p);
      weld[vi] = it->second;
    }
    return weld[vi];
  };
  auto id_of_point = [&](Vec3f p) {
    auto [it, inserted] = ids.emplace(key_of(p), static_cast<uint32_t>(points.size()));
    if (inserted) points.push_back(p);
    return it->second;
  };
  std::vector<EdgeSide> sides;
  sides.reserve(3 * m.triangle_count());
  auto add_triangle = [&](const uint32_t v[3]) {
    if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) return;  // degenerate: blocks nothing
    for (int k = 0; k < 3; ++k) {
      const uint32_t i = v[k], j = v[(k + 1) % 3];
      const uint64_t key = static_cast<uint64_t>(std::min(i, j)) << 32 | std::max(i, j);
      sides.push_back({key, static_cast<uint32_t>(sides.size()), v[(k + 2) % 3] | (i > j ? kReversed : 0u)});
    }
  };
  // The cut just in front of a one-sided light's plane (silhouette_edges.h).
  const float cut_depth = shader::ray_offset_epsilon(light.center);
  auto depth = [&](uint32_t id) { return dot(points[id] - light.center, light.n); };
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    const float alpha = opacity * (m.triangle_opacity.empty() ? 1.0f : m.triangle_opacity[t]);
    if (!(alpha > 0) || stops_part_of_the_light(alpha, obj.material)) continue;
    uint32_t v[3];
    for (int k = 0; k < 3; ++k) v[k] = id_of(m.indices[3 * t + k]);
    if (!light.one_sided) {
      add_triangle(v);
      continue;
    }
    const float z[3] = {depth(v[0]), depth(v[1]), depth(v[2])};
    const bool in[3] = {z[0] > cut_depth, z[1] > cut_depth, z[2] > cut_depth};
    if (in[0] && in[1] && in[2]) {
      add_triangle(v);
      continue;
    }
    // The polygon in front of the cut (3 or 4 corners, the triangle's winding), as a fan.
    uint32_t poly[4];
    int n = 0;
    for (int k = 0; k < 3; ++k) {
      const int i = k, j = (k + 1) % 3;
      if (in[i]) poly[n++] = v[i];
      if (in[i] != in[j]) {
        const int lo = v[i] < v[j] ? i : j, hi = lo == i ? j : i;
        const Vec3f a = points[v[lo]], b = points[v[hi]];
        poly[n++] = id_of_point(a + (b - a) * ((cut_depth - z[lo]) / (z[hi] - z[lo])));
      }
    }
    for (int q = 1; q + 1 < n; ++q) {
      const uint32_t tri[3] = {poly[0], poly[q], poly[q + 1]};
      add_triangle(tri);
    }
  }
  // Each edge's sides together, edges by key, sides in the triangles' order: a fixed order.
  std::sort(sides.begin(), sides.end(),
            [](const EdgeSide& x, const EdgeSide& y) { return x.key != y.key ? x.key < y.key : x.seq < y.seq; });
  std::vector<SilhouetteEdge> out;
  for (size_t first = 0; first < sides.size();) {
    size_t last = first + 1;
    while (last < sides.size() && sides[last].key == sides[first].key) ++last;
    const uint64_t key = sides[first].key;
    Vec3f a = points[key >> 32], b = points[key & 0xFFFFFFFFu];
    // a -> b along the first triangle's winding: on a consistently wound mesh, the planes
    // (b - a) x (w_0 - a) and -(b - a) x (w_1 - a) are then both triangles' outward sides,
    // the same for every edge (what the method's hierarchy bounds, NodeFacing).
    if (sides[first].third & kReversed) std::swap(a, b);
    auto third = [&](size_t i) { return points[sides[i].third & ~kReversed]; };
    if (last - first == 2) {
      const Vec3f w0 = third(first), w1 = third(first + 1);
      // §3.1: a silhouette for some light point iff the triangles face it differently; the
      // facing changes only where a point crosses one of the two planes.
      const bool cut = plane_cuts_region(a, b, w0, light) || plane_cuts_region(a, b, w1, light);
      const bool silhouette_from_centre = (side(a, b, light.center, w0) > 0) == (side(a, b, light.center, w1) > 0);
      if (cut || silhouette_from_centre) out.push_back({a, b, {w0, w1}, 2});
    } else {
      // Boundary edges (§3.4) and non-manifold ones (their triangles' parts add up).
      for (size_t i = first; i < last; i += 2) {
        SilhouetteEdge e{a, b, {third(i), Vec3f(0.0f)}, 1};
        if (i + 1 < last) {
          e.w[1] = third(i + 1);
          e.triangles = 2;
        }
        out.push_back(e);
      }
    }
    first = last;
  }
  return out;
}

}  // namespace

LightRegion light_region(const AreaLight& light) {
  LightRegion r;
  r.center = light.center;
  r.radius = light.extent_radius();
  r.planar = light.shape != LightShape::Ellipsoid;
  r.s = light.frame.s;
  r.t = light.frame.t;
  r.half = light.shape == LightShape::Rect ? light.size * 0.5f : Vec2f{light.radius, light.radius};
  r.one_sided = light.shape == LightShape::Rect || light.shape == LightShape::Disk;
  r.n = light.frame.n;
  return r;
}

std::vector<SilhouetteEdge> potential_silhouettes(const Scene& scene, const LightRegion& light) {
  // Objects are welded apart (an edge never joins two objects), so they are found at once and
  // joined in the scene's order: the result does not depend on the thread count.
  std::vector<std::vector<SilhouetteEdge>> per_object(scene.objects.size());
  parallel_for(scene.objects.size(), 1, [&](size_t begin, size_t end) {
    for (size_t o = begin; o < end; ++o) per_object[o] = object_silhouettes(scene.objects[o], light);
  });
  size_t total = 0;
  for (const auto& edges : per_object) total += edges.size();
  std::vector<SilhouetteEdge> out;
  out.reserve(total);
  for (auto& edges : per_object) {
    out.insert(out.end(), edges.begin(), edges.end());
    std::vector<SilhouetteEdge>().swap(edges);
  }
  return out;
}

}  // namespace penumbra::ssv
