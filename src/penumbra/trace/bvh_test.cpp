// TriangleBvh (trace/bvh.h): the tree over a wide scene's triangles is well formed (every
// triangle in one leaf, every box holding what lies below it) and the parallel build gives the
// serial build's tree node for node, whatever the threads.
#include "penumbra/trace/bvh.h"

#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// Small triangles scattered in clusters over a wide field (a forest's leaves, roughly), with a
// run of identical ones (every centroid equal: the median split).
std::vector<BvhTriangle> field(int count) {
  std::vector<BvhTriangle> tris;
  Rng rng(11, 3);
  for (int i = 0; i < count; ++i) {
    const int cluster = i / 500;
    const Vec3f c{(cluster % 10) * 6.0f + rng.next_float(), 2 + rng.next_float() * 3, (cluster / 10) * 6.0f + rng.next_float()};
    const Vec3f a = c + Vec3f(rng.next_float(), rng.next_float(), rng.next_float()) * 0.1f;
    const Vec3f b = c + Vec3f(rng.next_float(), rng.next_float(), rng.next_float()) * 0.1f;
    tris.push_back({c, a, b, static_cast<uint32_t>(cluster), static_cast<uint32_t>(i), 1.0f});
  }
  for (int i = 0; i < 300; ++i) tris.push_back({{1, 1, 1}, {1.1f, 1, 1}, {1, 1.1f, 1}, 999, static_cast<uint32_t>(i), 1.0f});
  return tris;
}

bool same_node(const BvhNode& a, const BvhNode& b) {
  return a.first == b.first && a.count == b.count && a.bounds.lo == b.bounds.lo && a.bounds.hi == b.bounds.hi;
}

bool same_triangle(const BvhTriangle& a, const BvhTriangle& b) {
  return a.v0 == b.v0 && a.v1 == b.v1 && a.v2 == b.v2 && a.object == b.object && a.prim == b.prim;
}

TEST(TriangleBvh, TheParallelBuildIsTheSerialTreeNodeForNode) {
  const std::vector<BvhTriangle> tris = field(60000);
  const TriangleBvh serial(tris, 4, SIZE_MAX);  // never splits in parallel
  for (size_t parallel_min : {size_t{64}, size_t{5000}, TriangleBvh::kParallelMinTriangles}) {
    for (int threads : {0, 1}) {
      ThreadLimit limit(threads);
      const TriangleBvh parallel(tris, 4, parallel_min);
      ASSERT_EQ(parallel.nodes().size(), serial.nodes().size()) << parallel_min;
      for (size_t i = 0; i < serial.nodes().size(); ++i)
        ASSERT_TRUE(same_node(parallel.nodes()[i], serial.nodes()[i])) << "node " << i << ", parallel_min " << parallel_min;
      for (size_t i = 0; i < tris.size(); ++i)
        ASSERT_TRUE(same_triangle(parallel.triangles()[i], serial.triangles()[i])) << "triangle " << i;
    }
  }
}

TEST(TriangleBvh, EveryTriangleIsInOneLeafInsideEveryBoxAboveIt) {
  const std::vector<BvhTriangle> tris = field(40000);
  const TriangleBvh bvh(tris, 4, 2048);
  const std::vector<BvhNode>& nodes = bvh.nodes();
  std::vector<int> seen(bvh.triangles().size(), 0);
  // Depth first from the root, each node's box against its parent's.
  std::vector<std::pair<uint32_t, uint32_t>> stack = {{0, 0}};
  size_t visited = 0;
  while (!stack.empty()) {
    const auto [index, parent] = stack.back();
    stack.pop_back();
    ASSERT_LT(index, nodes.size());
    const BvhNode& n = nodes[index];
    ++visited;
    const BvhNode& p = nodes[parent];
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(n.bounds.lo[k], p.bounds.lo[k]);
      EXPECT_LE(n.bounds.hi[k], p.bounds.hi[k]);
    }
    if (n.leaf()) {
      EXPECT_LE(n.count, 4u);
      for (uint32_t t = n.first; t < n.first + n.count; ++t) {
        ++seen[t];
        const BvhTriangle& tri = bvh.triangles()[t];
        for (const Vec3f& v : {tri.v0, tri.v1, tri.v2})
          for (int k = 0; k < 3; ++k) {
            EXPECT_GE(v[k], n.bounds.lo[k]);
            EXPECT_LE(v[k], n.bounds.hi[k]);
          }
      }
    } else {
      stack.push_back({n.first, index});
      stack.push_back({n.first + 1, index});
    }
  }
  EXPECT_EQ(visited, nodes.size());
  for (size_t t = 0; t < seen.size(); ++t) ASSERT_EQ(seen[t], 1) << "triangle " << t;
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
