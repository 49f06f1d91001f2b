// ssv-rt's potential silhouette edges of one light (Laine et al. 2005 §3.1) in a hierarchy,
// with the facing bounds that let a point skip the nodes holding no silhouette from it (§3.2).
// Built on the host once per light; the CPU version walks it per point, the GPU version
// (soft_shadow_volumes_gpu.cpp) uploads it.
#pragma once

#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadow/light_samples.h"
#include "penumbra/shadow/soft_shadow_volumes/depth_complexity.h"
#include "penumbra/shadow/soft_shadow_volumes/silhouette_edges.h"
#include "penumbra/shadow/soft_shadow_volumes/ssv_shared.h"
#include "penumbra/trace/bvh.h"

namespace penumbra::ssv {

// A hierarchy node's bound on the facing of its edges' triangles (§3.2: only edges that are
// silhouettes from the point matter), so that a whole subtree is skipped where the point sees
// all of its triangles from the front, or all from behind: then no edge in it is a silhouette
// from the point. The triangles' unit normals N (oriented so that an edge's two triangles
// agree: k_e = 0 iff N_A . (o - x) and N_B . (o - x) have one sign) lie within `spread` of the
// unit `axis`; their points lie in `box`. For every such plane through x in the box,
//   N . (o - x) >= axis . o - max_box(axis . x) - spread |o - x|,
// and symmetrically from above: one bound decides the whole node.
struct NodeFacing {
  Vec3f axis{0.0f};
  float spread = 0;
  Bounds3f box;
  bool cullable = false;  // false with a boundary or degenerate edge, or normals all around
  // From the above, for the test: the range of axis . x over the box, its centre and
  // half-diagonal.
  float h_lo = 0, h_hi = 0;
  Vec3f centre{0.0f};
  float half_diagonal = 0;
};

// Whether o sees every triangle of the node from the same side, with a margin far above the
// rounding, so that add_edge_crossings would find k_e = 0 for each edge (ssv_shared.h).
inline bool sees_all_alike(const NodeFacing& f, Vec3f o) {
  return f.cullable && shader::ssv_sees_all_alike(f.axis, f.spread, f.h_lo, f.h_hi, f.centre, f.half_diagonal, o);
}

struct EdgeHierarchy {
  // Edges per leaf: 8 measured 13% faster than 4 on the bunny (fewer nodes to test), 16 no better.
  static constexpr int kLeafSize = 8;

  // The potential silhouettes of `light` among the scene's casters (potential_silhouettes), in
  // a hierarchy over their boxes, with their facing tests.
  void build(const Scene& scene, const AreaLight& light);

  std::vector<SilhouetteEdge> edges;  // in bvh's leaf order
  std::vector<EdgeFacing> facing;     // the same order
  std::vector<NodeFacing> node_facing;  // per node of bvh
  TriangleBvh bvh;

 private:
  void build_node_facing();
};

// The base of every point's pyramid (§3.1's wedge test, soft_shadow_volumes.cpp): the light
// samples' bounding rectangle on the light's plane, a little larger (rounding), its corners in
// order around it, and its centre.
struct PyramidBase {
  Vec3f corners[4];
  Vec3f centre;
};
PyramidBase pyramid_base(const LightSamples& samples);

}  // namespace penumbra::ssv
