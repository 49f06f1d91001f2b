#include "penumbra/trace/bvh.h"

#include <algorithm>
#include <array>
#include <climits>
#include <cstdint>

#include "penumbra/core/parallel.h"

namespace penumbra {

namespace {

constexpr int kBins = 16;

float surface_area(const Bounds3f& b) {
  if (b.empty()) return 0;
  Vec3f d = b.diagonal();
  return 2 * (d.x * d.y + d.y * d.z + d.z * d.x);
}

Bounds3f triangle_bounds(const BvhTriangle& t) {
  Bounds3f b;
  b.extend(t.v0);
  b.extend(t.v1);
  b.extend(t.v2);
  return b;
}

// A node's range as the builder knows it before it splits it: its triangles' bounds and their
// centroids' bounds (each split hands its children theirs, found while it bins and partitions,
// so no pass over a range computes them again).
struct Range {
  uint32_t begin, end;
  Bounds3f bounds;
  Bounds3f centroid_bounds;
};

struct Builder {
  std::vector<BvhTriangle>& tris;
  std::vector<Vec3f> centroids;
  std::vector<Bounds3f> boxes;  // per triangle, reordered with tris
  int max_leaf;
  uint32_t parallel_min;  // nodes of at least this many triangles build their halves at once

  Range measure(uint32_t begin, uint32_t end) const {
    Range r{begin, end, {}, {}};
    for (uint32_t i = begin; i < end; ++i) {
      r.bounds.extend(boxes[i]);
      r.centroid_bounds.extend(centroids[i]);
    }
    return r;
  }

  // Chooses where a range splits (binned SAH along the widest centroid axis, or the median
  // where every centroid is equal) and partitions the triangles there; returns the two halves.
  std::array<Range, 2> partition(const Range& range) {
    const uint32_t begin = range.begin, end = range.end;
    uint32_t count = end - begin;
    const Bounds3f& cb = range.centroid_bounds;
    Vec3f extent = cb.diagonal();
    int axis = extent.x > extent.y ? (extent.x > extent.z ? 0 : 2) : (extent.y > extent.z ? 1 : 2);
    if (extent[axis] > 0) {
      // Binned SAH along the widest centroid axis.
      std::array<Bounds3f, kBins> bin_bounds;
      std::array<uint32_t, kBins> bin_count{};
      float lo = cb.lo[axis], scale = kBins / extent[axis];
      auto bin_of = [&](uint32_t i) { return std::min(kBins - 1, static_cast<int>((centroids[i][axis] - lo) * scale)); };
      for (uint32_t i = begin; i < end; ++i) {
        int b = bin_of(i);
        bin_count[b]++;
        bin_bounds[b].extend(boxes[i]);
      }
      // Split s puts bins [0, s) left: sweep the right sides once, then the left sides.
      std::array<Bounds3f, kBins> right_bounds;
      std::array<uint32_t, kBins> right_count{};
      {
        Bounds3f r;
        uint32_t nr = 0;
        for (int b = kBins - 1; b >= 1; --b) {
          r.extend(bin_bounds[b]);
          nr += bin_count[b];
          right_bounds[b] = r;
          right_count[b] = nr;
        }
      }
      float best_cost = kInfinity;
      int best_split = -1;
      Bounds3f l, best_left;
      uint32_t nl = 0;
      for (int s = 1; s < kBins; ++s) {
        l.extend(bin_bounds[s - 1]);
        nl += bin_count[s - 1];
        if (nl == 0 || right_count[s] == 0) continue;
        float cost = nl * surface_area(l) + right_count[s] * surface_area(right_bounds[s]);
        if (cost < best_cost) {
          best_cost = cost;
          best_split = s;
          best_left = l;
        }
      }
      if (best_split > 0) {
        std::array<Range, 2> halves{};
        uint32_t i = begin, j = end;
        while (i < j) {
          if (bin_of(i) < best_split) {
            halves[0].centroid_bounds.extend(centroids[i]);
            ++i;
          } else {
            --j;
            std::swap(tris[i], tris[j]);
            std::swap(centroids[i], centroids[j]);
            std::swap(boxes[i], boxes[j]);
            halves[1].centroid_bounds.extend(centroids[j]);
          }
        }
        // Both sides are non-empty (the split skips empty ones): the bins' unions are the
        // halves' bounds, exactly what a pass over their boxes would give.
        halves[0].begin = begin, halves[0].end = i, halves[0].bounds = best_left;
        halves[1].begin = i, halves[1].end = end, halves[1].bounds = right_bounds[best_split];
        return halves;
      }
    }
    // All centroids equal (nothing to bin): split by count, in the order they are in.
    const uint32_t mid = begin + count / 2;
    return {measure(begin, mid), measure(mid, end)};
  }

  // The subtree over a range into `nodes` from `node_index` on, depth first: a node's two
  // children are appended side by side, then the left child's subtree, then the right one's.
  void build(std::vector<BvhNode>& nodes, uint32_t node_index, const Range& range) {
    nodes[node_index].bounds = range.bounds;
    if (range.end - range.begin <= static_cast<uint32_t>(max_leaf)) {
      nodes[node_index].first = range.begin;
      nodes[node_index].count = range.end - range.begin;
      return;
    }
    const std::array<Range, 2> halves = partition(range);
    uint32_t left = static_cast<uint32_t>(nodes.size());
    nodes.emplace_back();
    nodes.emplace_back();
    nodes[node_index].first = left;
    nodes[node_index].count = 0;
    build(nodes, left, halves[0]);
    build(nodes, left + 1, halves[1]);
  }

  // The same subtree as build() gives, root first, with the two halves of a large node built at
  // once (their triangle ranges are disjoint) and spliced in build()'s order: the root, its two
  // children, the left child's descendants, the right child's. Node for node the serial tree.
  std::vector<BvhNode> build_parallel(const Range& range) {
    std::vector<BvhNode> out(1);
    const uint32_t count = range.end - range.begin;
    if (count < parallel_min || count <= static_cast<uint32_t>(max_leaf)) {
      build(out, 0, range);
      return out;
    }
    out[0].bounds = range.bounds;
    const std::array<Range, 2> halves = partition(range);
    std::vector<BvhNode> left, right;
    parallel_for(2, 1, [&](size_t first, size_t last) {
      for (size_t half = first; half < last; ++half) {
        if (half == 0) left = build_parallel(halves[0]);
        else right = build_parallel(halves[1]);
      }
    });
    // Local index j >= 1 of the left subtree lands at j + 2, of the right one at j + |left| + 1.
    const uint32_t left_shift = 2, right_shift = static_cast<uint32_t>(left.size()) + 1;
    auto moved = [](BvhNode n, uint32_t shift) {
      if (!n.leaf()) n.first += shift;
      return n;
    };
    out[0].first = 1;
    out[0].count = 0;
    out.reserve(1 + left.size() + right.size());
    out.push_back(moved(left[0], left_shift));
    out.push_back(moved(right[0], right_shift));
    for (size_t j = 1; j < left.size(); ++j) out.push_back(moved(left[j], left_shift));
    for (size_t j = 1; j < right.size(); ++j) out.push_back(moved(right[j], right_shift));
    return out;
  }
};

}  // namespace

uint64_t TriangleBvh::node_bound(uint64_t triangles, int max_leaf_size) {
  return 2 * (2 * triangles / static_cast<uint64_t>(std::max(1, max_leaf_size)) + 2);
}

uint64_t TriangleBvh::build_bytes(uint64_t triangles, int max_leaf_size) {
  return node_bound(triangles, max_leaf_size) * sizeof(BvhNode) + triangles * (sizeof(Vec3f) + sizeof(Bounds3f));
}

TriangleBvh::TriangleBvh(std::vector<BvhTriangle> triangles, int max_leaf_size, size_t parallel_min_triangles)
    : triangles_(std::move(triangles)) {
  if (triangles_.empty()) return;
  const uint32_t parallel_min =
      static_cast<uint32_t>(std::min<size_t>(std::max<size_t>(parallel_min_triangles, 2), UINT32_MAX));
  Builder b{triangles_, std::vector<Vec3f>(triangles_.size()), std::vector<Bounds3f>(triangles_.size()),
            std::max(1, max_leaf_size), parallel_min};
  parallel_for(triangles_.size(), 4096, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const BvhTriangle& t = triangles_[i];
      b.centroids[i] = (t.v0 + t.v1 + t.v2) / 3.0f;
      b.boxes[i] = triangle_bounds(t);
    }
  });
  nodes_ = b.build_parallel(b.measure(0, static_cast<uint32_t>(triangles_.size())));
}

std::vector<BvhTriangle> TriangleBvh::gather(const Scene& scene, bool skip_analytic_spheres) {
  std::vector<BvhTriangle> out;
  out.reserve(scene.triangle_count());
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& obj = scene.objects[o];
    if (skip_analytic_spheres && obj.sphere) continue;
    const TriangleMesh& m = obj.mesh;
    const bool textured = obj.material.alpha_textured() && m.uvs.size() == m.positions.size();
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      BvhTriangle bt{m.vertex(t, 0), m.vertex(t, 1), m.vertex(t, 2), static_cast<uint32_t>(o), static_cast<uint32_t>(t),
                     obj.material.opacity * (m.triangle_opacity.empty() ? 1.0f : m.triangle_opacity[t])};
      if (textured) {
        // Cone queries see whole triangles: an alpha texture counts as its mean opacity.
        const Vec2f uv[3] = {m.uvs[m.indices[3 * t]], m.uvs[m.indices[3 * t + 1]], m.uvs[m.indices[3 * t + 2]]};
        bt.opacity *= obj.material.alpha.mean_opacity(uv);
      }
      out.push_back(bt);
    }
  }
  return out;
}

}  // namespace penumbra
