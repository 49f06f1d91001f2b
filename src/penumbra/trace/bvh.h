// A bounding volume hierarchy over triangles for queries Embree does not offer (cone
// queries of parker1998's single-sample soft shadows). Binned-SAH build, flat node array of
// boxes.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

struct BvhTriangle {
  Vec3f v0, v1, v2;
  uint32_t object = 0, prim = 0;
  float opacity = 1.0f;
};

struct BvhNode {
  Bounds3f bounds;
  // Inner node: children at `first` and `first + 1`; leaf: triangles [first, first + count).
  uint32_t first = 0;
  uint32_t count = 0;  // 0 for an inner node
  bool leaf() const { return count != 0; }
};

class TriangleBvh {
 public:
  TriangleBvh() = default;
  // Builds over the given triangles (reordered into leaf order). Nodes of at least
  // `parallel_min_triangles` triangles build their two halves at once; the tree is the same,
  // node for node, whatever the threads.
  static constexpr size_t kParallelMinTriangles = 16384;
  explicit TriangleBvh(std::vector<BvhTriangle> triangles, int max_leaf_size = 4,
                       size_t parallel_min_triangles = kParallelMinTriangles);
  // Every triangle of every object of the scene, with its opacity (material x per-triangle x,
  // for an alpha texture, its mean over the triangle: SurfaceAlpha::mean_opacity).
  static std::vector<BvhTriangle> gather(const Scene& scene, bool skip_analytic_spheres);

  const std::vector<BvhNode>& nodes() const { return nodes_; }
  const std::vector<BvhTriangle>& triangles() const { return triangles_; }
  bool empty() const { return nodes_.empty(); }
  size_t memory_bytes() const {
    return nodes_.capacity() * sizeof(BvhNode) + triangles_.capacity() * sizeof(BvhTriangle);
  }
  // For memory estimates: the nodes a build over `triangles` triangles may allocate (leaves
  // hold half of max_leaf_size on average, which overflows the reserved 2 / max_leaf_size a
  // triangle once: the node array doubles), and what the build holds besides the triangles
  // handed to it (those nodes, each triangle's centroid and box).
  static uint64_t node_bound(uint64_t triangles, int max_leaf_size);
  static uint64_t build_bytes(uint64_t triangles, int max_leaf_size);

 private:
  std::vector<BvhNode> nodes_;
  std::vector<BvhTriangle> triangles_;
};

}  // namespace penumbra
