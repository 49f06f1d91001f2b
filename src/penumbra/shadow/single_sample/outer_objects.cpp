#include "penumbra/shadow/single_sample/outer_objects.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cstring>

#include "penumbra/core/parallel.h"
#include "penumbra/shadow/single_sample/simd4.h"

namespace penumbra::single_sample {

float triangle_cone_distance2(Vec3f o, Vec3f v, Vec3f e1, Vec3f e2, float near, float far, Vec3f a, Vec3f b,
                              Vec3f c) {
  return shader::ss_triangle_cone_distance2(o, v, e1, e2, near, far, a, b, c);
}

float triangle_cone_distance(Vec3f o, Vec3f v, Vec3f e1, Vec3f e2, float near, float far, Vec3f a, Vec3f b,
                             Vec3f c) {
  return std::sqrt(triangle_cone_distance2(o, v, e1, e2, near, far, a, b, c));
}

void TriangleBlock4::set(int lane, Vec3f a, Vec3f b, Vec3f c) {
  const Vec3f p[3] = {a, b, c};
  for (int k = 0; k < 3; ++k)
    for (int axis = 0; axis < 3; ++axis) v[k][axis][lane] = p[k][axis];
}

int block_cone_distance2_unclipped(const TriangleBlock4& block, Vec3f o, Vec3f v, Vec3f e1, Vec3f e2, float near,
                                   float far, float out[4]) {
  f4 t[3], qx[3], qy[3];
  i4 in_range = i4{-1, -1, -1, -1};
  for (int k = 0; k < 3; ++k) {
    f4 rx = load4(block.v[k][0]) - splat(o.x);
    f4 ry = load4(block.v[k][1]) - splat(o.y);
    f4 rz = load4(block.v[k][2]) - splat(o.z);
    t[k] = rx * splat(v.x) + ry * splat(v.y) + rz * splat(v.z);
    f4 x = rx * splat(e1.x) + ry * splat(e1.y) + rz * splat(e1.z);
    f4 y = rx * splat(e2.x) + ry * splat(e2.y) + rz * splat(e2.z);
    in_range &= (t[k] >= splat(near)) & (t[k] <= splat(far));
    // Lanes out of range are recomputed below; keep their arithmetic finite.
    f4 inv = splat(1.0f) / (in_range ? t[k] : splat(1.0f));
    qx[k] = x * inv;
    qy[k] = y * inv;
  }
  f4 best = splat(kInfinity);
  i4 pos = i4{0, 0, 0, 0}, neg = i4{0, 0, 0, 0};
  for (int k = 0; k < 3; ++k) {
    int k1 = k == 2 ? 0 : k + 1;
    f4 ex = qx[k1] - qx[k], ey = qy[k1] - qy[k];
    f4 side = ey * qx[k] - ex * qy[k];  // cross(e, -p)
    pos |= side > splat(0.0f);
    neg |= side < splat(0.0f);
    f4 len2 = ex * ex + ey * ey;
    f4 s = -(qx[k] * ex + qy[k] * ey) / (len2 > splat(0.0f) ? len2 : splat(1.0f));
    s = vmin4(vmax4(s, splat(0.0f)), splat(1.0f));
    f4 cx = qx[k] + s * ex, cy = qy[k] + s * ey;
    best = vmin4(best, cx * cx + cy * cy);
  }
  // Inside when every side has one sign (a projection of zero area has no inside).
  best = (pos ^ neg) ? splat(0.0f) : best;
  int mask = 0;
  for (int lane = 0; lane < 4; ++lane) {
    out[lane] = best[lane];
    if (!in_range[lane]) mask |= 1 << lane;
  }
  return mask;
}

void block_cone_distance2(const TriangleBlock4& block, Vec3f o, Vec3f v, Vec3f e1, Vec3f e2, float near, float far,
                          float out[4]) {
  int clip = block_cone_distance2_unclipped(block, o, v, e1, e2, near, far, out);
  for (int lane = 0; lane < 4; ++lane)
    if (clip & (1 << lane))
      out[lane] = triangle_cone_distance2(o, v, e1, e2, near, far, block.vertex(lane, 0), block.vertex(lane, 1),
                                          block.vertex(lane, 2));
}

uint64_t contour_bytes(uint64_t triangles, uint64_t vertices) {
  // canon, vertex_first; corners and vertex_tris (three per triangle).
  const uint64_t topology = 2 * vertices * sizeof(uint32_t) + 6 * triangles * sizeof(uint32_t);
  // build_topology's table (a power of two at least twice the vertices) and fill;
  // contour_triangles' welded positions, bucket starts and fill, one flag and three
  // half-edges (12 bytes each) per triangle.
  const uint64_t weld = 4 * vertices * sizeof(uint32_t) + vertices * sizeof(uint32_t);
  const uint64_t contour =
      vertices * (sizeof(Vec3f) + 2 * sizeof(uint32_t)) + triangles * (1 + 3 * 3 * sizeof(uint32_t));
  return topology + std::max(weld, contour);
}

MeshTopology build_topology(const TriangleMesh& mesh) {
  MeshTopology topo;
  const size_t nt = mesh.triangle_count();
  // Weld by exact position (-0 and +0 together) with an open-addressing hash table.
  const size_t np = mesh.positions.size();
  auto bits = [&](size_t i) {
    Vec3f p = mesh.positions[i] + Vec3f(0.0f);
    std::array<uint32_t, 3> b;
    std::memcpy(b.data(), &p, sizeof b);
    return b;
  };
  size_t cap = 16;
  while (cap < 2 * np) cap *= 2;
  std::vector<uint32_t> table(cap, ~0u);  // a representative mesh vertex, or empty
  topo.canon.resize(np);
  uint32_t nv = 0;
  for (size_t i = 0; i < np; ++i) {
    std::array<uint32_t, 3> b = bits(i);
    uint64_t h = (static_cast<uint64_t>(b[0]) * 0x9e3779b97f4a7c15ULL) ^ (static_cast<uint64_t>(b[1]) * 0xc2b2ae3d27d4eb4fULL) ^
                 (static_cast<uint64_t>(b[2]) * 0x165667b19e3779f9ULL);
    size_t slot = (h ^ (h >> 29)) & (cap - 1);
    while (table[slot] != ~0u && bits(table[slot]) != b) slot = (slot + 1) & (cap - 1);
    if (table[slot] == ~0u) {
      table[slot] = static_cast<uint32_t>(i);
      topo.canon[i] = nv++;
    } else {
      topo.canon[i] = topo.canon[table[slot]];
    }
  }
  topo.corners.resize(3 * nt);
  for (size_t i = 0; i < 3 * nt; ++i) topo.corners[i] = topo.canon[mesh.indices[i]];
  // Vertex -> triangles (counting sort).
  topo.vertex_first.assign(nv + 1, 0);
  for (size_t i = 0; i < 3 * nt; ++i) topo.vertex_first[topo.corners[i] + 1]++;
  for (size_t i = 0; i < nv; ++i) topo.vertex_first[i + 1] += topo.vertex_first[i];
  topo.vertex_tris.resize(topo.vertex_first[nv]);
  std::vector<uint32_t> fill(topo.vertex_first.begin(), topo.vertex_first.end() - 1);
  for (size_t i = 0; i < 3 * nt; ++i) topo.vertex_tris[fill[topo.corners[i]]++] = static_cast<uint32_t>(i / 3);
  return topo;
}

std::vector<uint8_t> contour_triangles(const TriangleMesh& mesh, const MeshTopology& topo, Vec3f light_pos,
                                       float band_radius) {
  const size_t nt = mesh.triangle_count();
  const size_t nv = topo.vertex_first.empty() ? 0 : topo.vertex_first.size() - 1;
  std::vector<uint8_t> keep(nt, 0);
  std::vector<Vec3f> pos(nv);  // welded vertices
  for (size_t i = 0; i < mesh.positions.size(); ++i) pos[topo.canon[i]] = mesh.positions[i];
  const uint32_t* corners = topo.corners.data();
  auto has_area = [&](size_t t) {
    uint32_t a = corners[3 * t], b = corners[3 * t + 1], c = corners[3 * t + 2];
    return a != b && b != c && c != a;
  };
  if (band_radius > 0)
    for (size_t t = 0; t < nt; ++t) {
      Vec3f a = pos[corners[3 * t]];
      Vec3f n = cross(pos[corners[3 * t + 1]] - a, pos[corners[3 * t + 2]] - a);
      float d = dot(n, light_pos - a);
      keep[t] = d * d < band_radius * band_radius * length_squared(n);
    }
  // Every edge of every triangle with area, bucketed by its lower welded vertex (counting
  // sort: two sequential passes over the triangles), each bucket then sorted by the upper
  // vertex (a handful of entries): the triangles of one edge end up side by side.
  struct HalfEdge {
    uint32_t other, code, opposite;  // upper vertex; 3 * triangle + edge; the corner off the edge
  };
  std::vector<uint32_t> first(nv + 1, 0);
  for (size_t t = 0; t < nt; ++t)
    if (has_area(t))
      for (int k = 0; k < 3; ++k) first[std::min(corners[3 * t + k], corners[3 * t + (k + 1) % 3]) + 1]++;
  for (size_t v = 0; v < nv; ++v) first[v + 1] += first[v];
  std::vector<HalfEdge> edges(first[nv]);
  {
    std::vector<uint32_t> fill(first.begin(), first.end() - 1);
    for (size_t t = 0; t < nt; ++t)
      if (has_area(t))
        for (int k = 0; k < 3; ++k) {
          uint32_t a = corners[3 * t + k], b = corners[3 * t + (k + 1) % 3];
          edges[fill[std::min(a, b)]++] = {std::max(a, b), static_cast<uint32_t>(3 * t + k), corners[3 * t + (k + 2) % 3]};
        }
  }
  // Buckets are independent: in parallel (a triangle may be marked from two buckets:
  // relaxed atomic stores of the same value).
  parallel_for(nv, 2048, [&](size_t va, size_t vb) {
  for (uint32_t a = static_cast<uint32_t>(va); a < vb; ++a) {
    HalfEdge* bucket = edges.data() + first[a];
    const size_t n = first[a + 1] - first[a];
    for (size_t i = 1; i < n; ++i)  // insertion sort
      for (size_t j = i; j > 0 && bucket[j].other < bucket[j - 1].other; --j) std::swap(bucket[j], bucket[j - 1]);
    for (size_t i = 0; i < n;) {
      size_t j = i + 1;
      while (j < n && bucket[j].other == bucket[i].other) ++j;
      bool contour = true;  // boundary (one triangle) or non-manifold (three or more)
      if (j - i == 2) {
        const uint32_t b = bucket[i].other;
        Vec3f ea = pos[a], eb = pos[b];
        Vec3f c0 = pos[bucket[i].opposite], c1 = pos[bucket[i + 1].opposite];
        // Seen from the light, the two triangles lie on the same side of the edge (the
        // surface folds away: a contour edge) when their free corners are on the same side
        // of the plane through the edge and the light.
        Vec3f nrm = cross(eb - ea, light_pos - ea);
        contour = dot(nrm, c0 - ea) * dot(nrm, c1 - ea) >= 0.0f;  // same side, or in the plane
      }
      if (contour)
        for (size_t q = i; q < j; ++q) std::atomic_ref<uint8_t>(keep[bucket[q].code / 3]).store(1, std::memory_order_relaxed);
      i = j;
    }
  }
  });
  return keep;
}

}  // namespace penumbra::single_sample
