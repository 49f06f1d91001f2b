#include "penumbra/gpu/bvh_builder.h"

#include <embree3/rtcore.h>

#include <algorithm>

#include "penumbra/core/error.h"

namespace penumbra::gpu {
namespace {

RTCDevice builder_device() {
  static RTCDevice device = [] {
    RTCDevice d = rtcNewDevice(nullptr);
    if (!d) throw Error("Embree: cannot create a device for the GPU's BVH builder");
    return d;
  }();
  return device;
}

// The builder's own tree, allocated by Embree's thread-local allocator (freed with the RTCBVH).
struct BuildNode {
  bool leaf = false;
  // Inner: two children and their boxes. Leaf: the items.
  BuildNode* child[2] = {nullptr, nullptr};
  RTCBounds box[2];
  uint32_t first = 0, count = 0;  // leaf: into the leaf-item list assembled below
  const uint32_t* prim_ids = nullptr;  // leaf: its primitives' indices
};

void* create_node(RTCThreadLocalAllocator alloc, unsigned int children, void*) {
  void* p = rtcThreadLocalAlloc(alloc, sizeof(BuildNode), 16);
  return new (p) BuildNode();
}

void set_children(void* node, void** children, unsigned int count, void*) {
  auto* n = static_cast<BuildNode*>(node);
  for (unsigned i = 0; i < count && i < 2; ++i) n->child[i] = static_cast<BuildNode*>(children[i]);
}

void set_bounds(void* node, const RTCBounds** bounds, unsigned int count, void*) {
  auto* n = static_cast<BuildNode*>(node);
  for (unsigned i = 0; i < count && i < 2; ++i) n->box[i] = *bounds[i];
}

void* create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims, size_t count, void*) {
  // The primitives' indices are copied (Embree reuses the array after the call), and only they:
  // an RTCBuildPrimitive wants 32-byte alignment, which the space after the node lacks.
  void* p = rtcThreadLocalAlloc(alloc, sizeof(BuildNode) + count * sizeof(uint32_t), 16);
  auto* n = new (p) BuildNode();
  auto* ids = reinterpret_cast<uint32_t*>(n + 1);
  for (size_t i = 0; i < count; ++i) ids[i] = prims[i].primID;
  n->leaf = true;
  n->prim_ids = ids;
  n->count = static_cast<uint32_t>(count);
  return n;
}

Vec3f lo_of(const RTCBounds& b) { return {b.lower_x, b.lower_y, b.lower_z}; }
Vec3f hi_of(const RTCBounds& b) { return {b.upper_x, b.upper_y, b.upper_z}; }

// Depth-first flattening: node i's children get indices after it.
struct Flattener {
  FlatBvh* out;
  uint32_t add_node() {
    out->nodes.push_back({});
    return static_cast<uint32_t>(out->nodes.size() - 1);
  }
  // Writes child slot k of node `index` for builder node `c` with box `box`.
  void set_child(uint32_t index, int k, const BuildNode* c, Vec3f lo, Vec3f hi) {
    uint32_t child = 0, count = 0;
    if (c->leaf) {
      child = static_cast<uint32_t>(out->order.size());
      count = c->count;
      for (uint32_t i = 0; i < c->count; ++i) out->order.push_back(c->prim_ids[i]);
    } else {
      child = flatten(c);
    }
    shader::GpuBvhNode& n = out->nodes[index];
    (k == 0 ? n.lo0 : n.lo1) = lo;
    (k == 0 ? n.hi0 : n.hi1) = hi;
    (k == 0 ? n.child0 : n.child1) = child;
    (k == 0 ? n.count0 : n.count1) = count;
  }
  uint32_t flatten(const BuildNode* b) {
    const uint32_t index = add_node();
    for (int k = 0; k < 2; ++k) set_child(index, k, b->child[k], lo_of(b->box[k]), hi_of(b->box[k]));
    return index;
  }
};

void set_empty(shader::GpuBvhNode& n, int k) {
  (k == 0 ? n.lo0 : n.lo1) = Vec3f(kInfinity);
  (k == 0 ? n.hi0 : n.hi1) = Vec3f(-kInfinity);
  (k == 0 ? n.child0 : n.child1) = shader::kEmptyChild;
  (k == 0 ? n.count0 : n.count1) = 0;
}

}  // namespace

FlatBvh build_bvh(std::span<const Bounds3f> boxes, int max_leaf_size) {
  FlatBvh out;
  const size_t n = boxes.size();
  if (n == 0) {
    out.nodes.resize(1);
    set_empty(out.nodes[0], 0);
    set_empty(out.nodes[0], 1);
    return out;
  }
  std::vector<RTCBuildPrimitive> prims(n);
  for (size_t i = 0; i < n; ++i) {
    const Bounds3f& b = boxes[i];
    prims[i] = RTCBuildPrimitive{b.lo.x, b.lo.y, b.lo.z, 0u, b.hi.x, b.hi.y, b.hi.z, static_cast<unsigned>(i)};
  }
  RTCBVH bvh = rtcNewBVH(builder_device());
  RTCBuildArguments args = rtcDefaultBuildArguments();
  args.byteSize = sizeof(args);
  args.buildFlags = RTC_BUILD_FLAG_NONE;
  args.buildQuality = RTC_BUILD_QUALITY_MEDIUM;  // no spatial splits: each item in one leaf
  args.maxBranchingFactor = 2;
  args.maxDepth = kMaxBvhDepth;
  args.sahBlockSize = 1;
  args.minLeafSize = 1;
  args.maxLeafSize = static_cast<unsigned>(std::max(1, max_leaf_size));
  args.traversalCost = 1.0f;
  args.intersectionCost = 1.0f;
  args.bvh = bvh;
  args.primitives = prims.data();
  args.primitiveCount = n;
  args.primitiveArrayCapacity = n;
  args.createNode = create_node;
  args.setNodeChildren = set_children;
  args.setNodeBounds = set_bounds;
  args.createLeaf = create_leaf;
  args.splitPrimitive = nullptr;
  auto* root = static_cast<BuildNode*>(rtcBuildBVH(&args));
  if (!root) {
    rtcReleaseBVH(bvh);
    throw Error("Embree: rtcBuildBVH failed over {} items (error {})", n,
                static_cast<int>(rtcGetDeviceError(builder_device())));
  }
  out.nodes.reserve(n);
  out.order.reserve(n);
  Flattener f{&out};
  if (root->leaf) {
    // A single leaf: a root node whose second child is empty.
    Bounds3f all;
    for (const Bounds3f& b : boxes) all.extend(b);
    const uint32_t index = f.add_node();
    set_empty(out.nodes[index], 1);
    f.set_child(index, 0, root, all.lo, all.hi);
  } else {
    f.flatten(root);
  }
  rtcReleaseBVH(bvh);
  return out;
}

void refit_bvh(FlatBvh& bvh, std::span<const Bounds3f> boxes) {
  // Children come after their parents, so one backward pass sees every child before its parent.
  auto child_box = [&](uint32_t child, uint32_t count, Bounds3f* b) {
    if (child == shader::kEmptyChild) return;
    if (count > 0) {
      for (uint32_t i = 0; i < count; ++i) b->extend(boxes[bvh.order[child + i]]);
    } else {
      const shader::GpuBvhNode& c = bvh.nodes[child];
      b->extend(Bounds3f{c.lo0, c.hi0});
      b->extend(Bounds3f{c.lo1, c.hi1});
    }
  };
  for (size_t i = bvh.nodes.size(); i-- > 0;) {
    shader::GpuBvhNode& n = bvh.nodes[i];
    Bounds3f b0, b1;
    child_box(n.child0, n.count0, &b0);
    child_box(n.child1, n.count1, &b1);
    if (n.child0 != shader::kEmptyChild) n.lo0 = b0.lo, n.hi0 = b0.hi;
    if (n.child1 != shader::kEmptyChild) n.lo1 = b1.lo, n.hi1 = b1.hi;
  }
}

}  // namespace penumbra::gpu
