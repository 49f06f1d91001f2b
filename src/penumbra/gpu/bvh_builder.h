// BVHs for the GPU, built on the CPU by Embree's own builder (rtcBuildBVH: binned SAH, the
// builder of Embree's BVH2, run in parallel) and flattened into the node layout of
// gpu/scene_layout_shared.h. penumbra writes no BVH builder of its own; what it adds is the
// layout, the flattening and the refit.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/gpu/scene_layout_shared.h"

namespace penumbra::gpu {

struct FlatBvh {
  // Nodes in depth-first order (a parent before its children; node 0 is the root). Child
  // indices are relative: a node child is an index into `nodes`, a leaf child an index into
  // `order`; GpuScene adds each array's offset when it concatenates several BVHs.
  std::vector<shader::GpuBvhNode> nodes;
  // Leaf items in the order the leaves reference them: order[i] is an index into the boxes
  // the BVH was built over.
  std::vector<uint32_t> order;
};

// A binary BVH over `boxes` (SAH, at most max_leaf_size items a leaf, at most 40 levels below
// the root: the GPU traversal's stack is sized for it). An empty input gives a root with two
// empty children.
FlatBvh build_bvh(std::span<const Bounds3f> boxes, int max_leaf_size);

// New boxes for the same items (boxes[i] for the item the BVH was built over as i): every
// node's child boxes recomputed bottom-up, the topology kept (a refit: cheaper than a build,
// and as good while the items move together, as an animated object's triangles do).
void refit_bvh(FlatBvh& bvh, std::span<const Bounds3f> boxes);

// The largest stack a traversal of a BLAS (or the TLAS) needs: what bvh_traverse.glsl holds.
inline constexpr int kMaxBvhDepth = 40;

}  // namespace penumbra::gpu
