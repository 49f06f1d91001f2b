#include "penumbra/shadow/soft_shadow_volumes/edge_hierarchy.h"

#include <algorithm>

#include "penumbra/core/parallel.h"

namespace penumbra::ssv {

void EdgeHierarchy::build(const Scene& scene, const AreaLight& light) {
  edges = potential_silhouettes(scene, light_region(light));
  std::vector<BvhTriangle> boxes(edges.size());
  for (size_t i = 0; i < edges.size(); ++i) {
    boxes[i].v0 = edges[i].a;
    boxes[i].v1 = boxes[i].v2 = edges[i].b;
    boxes[i].prim = static_cast<uint32_t>(i);
  }
  bvh = TriangleBvh(std::move(boxes), kLeafSize);
  // The edges in the hierarchy's leaf order (a leaf's edges side by side), with their
  // quick facing test.
  {
    const std::vector<BvhTriangle>& order = bvh.triangles();
    std::vector<SilhouetteEdge> ordered(edges.size());
    facing.resize(edges.size());
    parallel_for(edges.size(), 4096, [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        ordered[i] = edges[order[i].prim];
        facing[i] = edge_facing(ordered[i]);
      }
    });
    edges = std::move(ordered);
  }
  build_node_facing();
}

// Bottom-up over the hierarchy (children come after their parent in bvh.nodes()).
void EdgeHierarchy::build_node_facing() {
  const std::vector<BvhNode>& nodes = bvh.nodes();
  node_facing.assign(nodes.size(), NodeFacing{});
  std::vector<Vec3f> normals;  // a leaf's, reused
  for (size_t k = nodes.size(); k-- > 0;) {
    const BvhNode& node = nodes[k];
    NodeFacing& f = node_facing[k];
    normals.clear();
    f.cullable = true;
    if (node.leaf()) {
      for (uint32_t i = node.first; i < node.first + node.count; ++i) {
        const SilhouetteEdge& e = edges[i];
        const EdgeFacing& ef = facing[i];
        for (Vec3f p : {e.a, e.b, e.w[0]}) f.box.extend(p);
        if (e.triangles == 2) f.box.extend(e.w[1]);
        if (!ef.two_sided || !(ef.scale[0] > 0) || !(ef.scale[1] > 0)) {
          f.cullable = false;
          continue;
        }
        // n_0 and -n_1 (EdgeFacing orients both by (a, b, w): opposite for a consistent pair).
        normals.push_back(ef.n[0] / ef.scale[0]);
        normals.push_back(-ef.n[1] / ef.scale[1]);
      }
      Vec3f sum(0.0f);
      for (Vec3f n : normals) sum = sum + n;
      const float len = length(sum);
      if (!(len > 1e-3f * static_cast<float>(normals.size()))) f.cullable = false;
      if (!f.cullable) continue;
      f.axis = sum / len;
      for (Vec3f n : normals) f.spread = std::max(f.spread, length(n - f.axis));
    } else {
      const NodeFacing& l = node_facing[node.first];
      const NodeFacing& r = node_facing[node.first + 1];
      f.box = l.box;
      f.box.extend(r.box);
      const Vec3f sum = l.axis + r.axis;
      const float len = length(sum);
      f.cullable = l.cullable && r.cullable && len > 1e-3f;
      if (!f.cullable) continue;
      f.axis = sum / len;
      f.spread = std::max(l.spread + length(l.axis - f.axis), r.spread + length(r.axis - f.axis));
    }
    // Normals more than 90 degrees apart: no side is common to all.
    if (f.spread >= 1.0f) f.cullable = false;
    if (!f.cullable) continue;
    f.h_lo = kInfinity, f.h_hi = -kInfinity;
    for (int i = 0; i < 8; ++i) {
      const float h = dot(f.axis, f.box.corner(i));
      f.h_lo = std::min(f.h_lo, h);
      f.h_hi = std::max(f.h_hi, h);
    }
    f.centre = f.box.center();
    f.half_diagonal = 0.5f * length(f.box.diagonal());
  }
}

PyramidBase pyramid_base(const LightSamples& samples) {
  float x0 = kInfinity, x1 = -kInfinity, y0 = kInfinity, y1 = -kInfinity;
  for (Vec2f u : samples.local) {
    x0 = std::min(x0, u.x), x1 = std::max(x1, u.x), y0 = std::min(y0, u.y), y1 = std::max(y1, u.y);
  }
  const float pad = 1e-3f * std::max(1.0f, std::max(x1 - x0, y1 - y0));
  x0 -= pad, x1 += pad, y0 -= pad, y1 += pad;
  const float R = samples.radius;
  PyramidBase b;
  b.corners[0] = samples.center + samples.s * (R * x0) + samples.t * (R * y0);
  b.corners[1] = samples.center + samples.s * (R * x1) + samples.t * (R * y0);
  b.corners[2] = samples.center + samples.s * (R * x1) + samples.t * (R * y1);
  b.corners[3] = samples.center + samples.s * (R * x0) + samples.t * (R * y1);
  b.centre = (b.corners[0] + b.corners[2]) * 0.5f;
  return b;
}

}  // namespace penumbra::ssv
