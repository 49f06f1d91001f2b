// `single-sample` on the GPU (parker1998; issue 29): one thread per view sample traces the hard
// shadow ray through the GpuScene's BVH (the inner objects) and, where it passes, searches the
// method's own occluder BVH in cone space (kernels/single_sample_search.comp).
//
// Why its own BVH, not the GpuScene's: parker1998's outer objects are found by a search that prunes
// by a shrinking cone, over a candidate set the CPU chooses per light (the triangles along each
// opaque mesh's contour seen from the light centre, occluders.h), in a frame centred on the light
// where those slivers have thin boxes. The scene's BVH holds every triangle in world-axis boxes
// built for ray hits: searching it would test every triangle near the cone (the paper's own way,
// every box grown by b_max, which the CPU version measured 2-3 times slower) and give
// candidates=contour's picture only by filtering. So prepare() builds the CPU's occluders with the
// CPU's code and uploads its TriangleBvh as it is (nodes, triangles, planes: byte for byte
// single_sample_shared.h's SsNode, SsTriangle, SsPlane). Same parameters as single_sample.cpp's
// table; `neighbours` is not on the GPU yet (a one-line error), `packet` changes nothing here.
#include <algorithm>

#include "penumbra/core/error.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/single_sample/occluders.h"
#include "penumbra/shadow/single_sample/single_sample_gpu.h"
#include "penumbra/shadow/single_sample/single_sample_kernels_shared.h"

namespace penumbra {
namespace {

using shader::SsCounters;
using shader::SsNode;
using shader::SsPlane;
using shader::SsSetup;
using shader::SsSphere;
using shader::SsTriangle;

// The CPU's BVH records are the GPU's.
static_assert(sizeof(BvhTriangle) == sizeof(SsTriangle) && offsetof(BvhTriangle, object) == offsetof(SsTriangle, object) &&
              offsetof(BvhTriangle, opacity) == offsetof(SsTriangle, opacity));
static_assert(sizeof(BvhNode) == sizeof(SsNode) && offsetof(BvhNode, first) == offsetof(SsNode, first) &&
              offsetof(BvhNode, count) == offsetof(SsNode, count));

int g_stack_levels_for_testing = 0;

// The most BVH levels the search takes: its stack holds one entry a level and the root.
int stack_levels() { return g_stack_levels_for_testing > 0 ? g_stack_levels_for_testing : shader::kSsStack - 1; }

// The levels of the BVH below node 0 (a leaf alone: 1).
int bvh_depth(const TriangleBvh& bvh) {
  if (bvh.empty()) return 0;
  int deepest = 0;
  std::vector<std::pair<uint32_t, int>> stack = {{0u, 1}};
  while (!stack.empty()) {
    auto [index, depth] = stack.back();
    stack.pop_back();
    deepest = std::max(deepest, depth);
    const BvhNode& n = bvh.nodes()[index];
    if (n.leaf()) continue;
    stack.push_back({n.first, depth + 1});
    stack.push_back({n.first + 1, depth + 1});
  }
  return deepest;
}

class SingleSampleGpu final : public GpuShadowMethod {
 public:
  explicit SingleSampleGpu(const ParamSet& p) : settings_(single_sample::occluder_settings(p)) {
    if (settings_.ring)
      throw Error("single-sample: neighbours=true has no GPU version yet: run it with --device cpu, or leave "
                  "neighbours out");
    const std::string& c = p.get_string("combine");
    combine_ = c == "min" ? 0u : (c == "multiply" ? 1u : 2u);
  }

  void prepare(const ShadowContext& ctx, GpuFrame& frame) override {
    stats_.prepare_count++;
    gpu::Device& device = *frame.device;
    const single_sample::Occluders occ = single_sample::build_occluders(*ctx.scene, *ctx.light, settings_);
    // The search's stack holds one entry a level (and the root): a deeper BVH is refused, never
    // searched in part.
    const int depth = bvh_depth(occ.bvh);
    if (depth > stack_levels())
      throw Error("single-sample on the GPU: the occluder BVH is {} levels deep, more than the {} the search's stack "
                  "holds: raise leaf_size, or run it with --device cpu",
                  depth, stack_levels());
    SsSetup setup{};
    setup.light_pos = occ.light_pos;
    setup.diameter = occ.diameter;
    setup.frame_s = occ.light_frame.s;
    setup.plane_eps = occ.plane_eps;
    setup.frame_t = occ.light_frame.t;
    setup.combine = combine_;
    setup.frame_n = occ.light_frame.n;
    setup.sphere_count = static_cast<uint32_t>(occ.spheres.size());
    setup.node_count = static_cast<uint32_t>(occ.bvh.nodes().size());
    setup_ = gpu::make_buffer<SsSetup>(device, std::span(&setup, 1), "single-sample's set-up");
    nodes_ = gpu::Buffer(device, std::max<uint64_t>(1, occ.bvh.nodes().size()) * sizeof(SsNode), "single-sample's BVH nodes");
    triangles_ = gpu::Buffer(device, std::max<uint64_t>(1, occ.bvh.triangles().size()) * sizeof(SsTriangle),
                             "single-sample's occluder triangles");
    planes_ = gpu::Buffer(device, std::max<uint64_t>(1, occ.planes.size()) * sizeof(SsPlane),
                          "single-sample's triangle planes");
    if (!occ.bvh.empty()) {
      nodes_.upload(occ.bvh.nodes().data(), occ.bvh.nodes().size() * sizeof(SsNode));
      triangles_.upload(occ.bvh.triangles().data(), occ.bvh.triangles().size() * sizeof(SsTriangle));
      planes_.upload(occ.planes.data(), occ.planes.size() * sizeof(SsPlane));
    }
    std::vector<SsSphere> spheres;
    for (const single_sample::AnalyticSphere& s : occ.spheres)
      spheres.push_back({s.shape.center, s.shape.radius, s.object, s.opacity});
    spheres_ = gpu::make_buffer<SsSphere>(device, spheres, "single-sample's spheres");
    counters_ = gpu::Buffer(device, sizeof(SsCounters), "single-sample's counters");
    occluders_ = occ.bvh.triangles().size();
    all_triangles_ = occ.all_triangles;
  }

  void evaluate(const ShadowContext&, GpuFrame& frame, const GpuShadowOutput& out) override {
    gpu::CommandList& cl = *frame.commands;
    cl.stage("shadow rays");
    if (!counting_) cl.fill(counters_, 0);
    counting_ = true;
    shader::SingleSampleParams p{};
    p.scene = frame.scene->address();
    p.samples = frame.view_samples;
    p.visibility = out.visibility;
    p.setup = setup_.address();
    p.nodes = nodes_.address();
    p.triangles = triangles_.address();
    p.planes = planes_.address();
    p.spheres = spheres_.address();
    p.counters = counters_.address();
    p.slots = frame.slots;
    cl.dispatch("single_sample_search", frame.slots, p);
    stats_.memory_bytes = setup_.bytes() + nodes_.bytes() + triangles_.bytes() + planes_.bytes() + spheres_.bytes() +
                          counters_.bytes();
  }

  // The CPU's statistics (single_sample.cpp), counted on the device.
  void collect_stats() override {
    if (!counting_) return;
    SsCounters c{};
    counters_.download(&c, sizeof(c));
    counting_ = false;
    stats_.rays_traced += c.rays;
    stats_.texels_visited += c.nodes;
    const double n = std::max<uint32_t>(1, c.rays);
    stats_.extra["occluder_triangles"] = occluders_;
    stats_.extra["occluder_fraction"] = all_triangles_ ? static_cast<double>(occluders_) / all_triangles_ : 0.0;
    stats_.extra["bvh_nodes_per_ray"] = c.nodes / n;
    stats_.extra["triangle_tests_per_ray"] = c.tests / n;
    stats_.extra["hard_blocked_fraction"] = c.blocked / n;
    stats_.extra["searched_fraction"] = c.searched / n;
    stats_.extra["clipped_tests_per_ray"] = c.clipped / n;
  }

 private:
  single_sample::OccluderSettings settings_;
  uint32_t combine_ = 0;
  gpu::Buffer setup_, nodes_, triangles_, planes_, spheres_, counters_;
  uint64_t occluders_ = 0, all_triangles_ = 0;
  bool counting_ = false;
};

// One light's instance on the device, per scene triangle (at most every one is an occluder): the
// BVH's nodes (TriangleBvh::node_bound), triangles and planes; the spheres, set-up and counters.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  const uint64_t nodes = TriangleBvh::node_bound(q.triangles, p.get_int("leaf_size"));
  MemoryTally tally;
  tally.add(nodes * sizeof(SsNode) + q.triangles * (sizeof(SsTriangle) + sizeof(SsPlane)) + 3 * 64, kTrianglesSetting);
  tally.add(sizeof(SsSetup) + sizeof(SsCounters) + 16, "leaf_size");
  return tally.estimate();
}

const GpuMethodRegistration registration({"single-sample",
                                          [](const ParamSet& p) { return std::make_unique<SingleSampleGpu>(p); },
                                          memory});

}  // namespace

void single_sample::set_gpu_stack_levels_for_testing(int levels) { g_stack_levels_for_testing = levels; }

}  // namespace penumbra
