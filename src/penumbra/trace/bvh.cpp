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

struct Builder {
  std::vector<BvhTriangle>& tris;
  std::vector<Vec3f> centroids;
  std::vector<Bounds3f> boxes;  // per triangle, reordered with tris
  int max_leaf;
  uint32_t parallel_min;  // nodes of at least this many triangles build their halves at once

  void finish_node(BvhNode& n, uint32_t begin, uint32_t end) {
    Bounds3f b;
    for (uint32_t i = begin; i < end; ++i) b.extend(boxes[i]);
    n.bounds = b;
  }

  // Chooses where [begin, end) splits (binned SAH along the widest centroid axis, or the median
  // where every centroid is equal) and partitions the triangles there; returns the split.
  uint32_t partition(uint32_t begin, uint32_t end) {
    uint32_t count = end - begin;
    Bounds3f cb;
    for (uint32_t i = begin; i < end; ++i) cb.extend(centroids[i]);
    Vec3f extent = cb.diagonal();
    int axis = extent.x > extent.y ? (extent.x > extent.z ? 0 : 2) : (extent.y > extent.z ? 1 : 2);
    uint32_t mid = begin + count / 2;
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
      std::array<float, kBins> right_area{};
      std::array<uint32_t, kBins> right_count{};
      {
        Bounds3f r;
        uint32_t nr = 0;
        for (int b = kBins - 1; b >= 1; --b) {
          r.extend(bin_bounds[b]);
          nr += bin_count[b];
          right_area[b] = surface_area(r);
          right_count[b] = nr;
        }
      }
      float best_cost = kInfinity;
      int best_split = -1;
      Bounds3f l;
      uint32_t nl = 0;
      for (int s = 1; s < kBins; ++s) {
        l.extend(bin_bounds[s - 1]);
        nl += bin_count[s - 1];
        if (nl == 0 || right_count[s] == 0) continue;
        float cost = nl * surface_area(l) + right_count[s] * right_area[s];
        if (cost < best_cost) { best_cost = cost; best_split = s; }
      }
      if (best_split > 0) {
        uint32_t i = begin, j = end;
        while (i < j) {
          if (bin_of(i) < best_split) ++i;
          else {
            --j;
            std::swap(tris[i], tris[j]);
            std::swap(centroids[i], centroids[j]);
            std::swap(boxes[i], boxes[j]);
          }
        }
        mid = i;
      }
    }
    if (mid == begin || mid == end) {  // all centroids equal: split by count
      mid = begin + count / 2;
      std::vector<uint32_t> order(count);
      for (uint32_t i = 0; i < count; ++i) order[i] = begin + i;
      std::nth_element(order.begin(), order.begin() + count / 2, order.end(),
                       [&](uint32_t a, uint32_t b) { return centroids[a][axis] < centroids[b][axis]; });
      std::vector<BvhTriangle> t2;
      std::vector<Vec3f> c2;
      std::vector<Bounds3f> b2;
      for (uint32_t k : order) { t2.push_back(tris[k]); c2.push_back(centroids[k]); b2.push_back(boxes[k]); }
      std::copy(t2.begin(), t2.end(), tris.begin() + begin);
      std::copy(c2.begin(), c2.end(), centroids.begin() + begin);
      std::copy(b2.begin(), b2.end(), boxes.begin() + begin);
    }
    return mid;
  }

  // The subtree over [begin, end) into `nodes` from `node_index` on, depth first: a node's two
  // children are appended side by side, then the left child's subtree, then the right one's.
  void build(std::vector<BvhNode>& nodes, uint32_t node_index, uint32_t begin, uint32_t end) {
    finish_node(nodes[node_index], begin, end);
    if (end - begin <= static_cast<uint32_t>(max_leaf)) {
      nodes[node_index].first = begin;
      nodes[node_index].count = end - begin;
      return;
    }
    const uint32_t mid = partition(begin, end);
    uint32_t left = static_cast<uint32_t>(nodes.size());
    nodes.emplace_back();
    nodes.emplace_back();
    nodes[node_index].first = left;
    nodes[node_index].count = 0;
    build(nodes, left, begin, mid);
    build(nodes, left + 1, mid, end);
  }

  // The same subtree as build() gives, root first, with the two halves of a large node built at
  // once (their triangle ranges are disjoint) and spliced in build()'s order: the root, its two
  // children, the left child's descendants, the right child's. Node for node the serial tree.
  std::vector<BvhNode> build_parallel(uint32_t begin, uint32_t end) {
    std::vector<BvhNode> out(1);
    if (end - begin < parallel_min || end - begin <= static_cast<uint32_t>(max_leaf)) {
      build(out, 0, begin, end);
      return out;
    }
    finish_node(out[0], begin, end);
    const uint32_t mid = partition(begin, end);
    std::vector<BvhNode> left, right;
    parallel_for(2, 1, [&](size_t first, size_t last) {
      for (size_t half = first; half < last; ++half) {
        if (half == 0) left = build_parallel(begin, mid);
        else right = build_parallel(mid, end);
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
  nodes_ = b.build_parallel(0, static_cast<uint32_t>(triangles_.size()));
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
