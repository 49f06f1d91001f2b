// `ssv-rt` on the GPU (Laine, Aila, Assarsson, Lehtinen, Akenine-Moller 2005): the potential
// silhouette edges of the light and their hierarchy built on the host by the CPU version's code
// (edge_hierarchy.h, §3.1) and uploaded once per light; per view sample one work group of
// kernels/ssv_evaluate.comp: the reference ray's surface count (§3.3), the hierarchy walked with
// the point's pyramid, the depth complexity of each of the N fixed light samples (the CPU's set,
// shadow/light_samples.h) updated per edge in shared memory (§3.2, ssv_shared.h: the per-edge
// set-up in double and the per-sample tests the CPU runs). Nothing grows with the frame: no list
// can overflow. docs/methods/ssv-rt.md, "On the GPU".
#include <algorithm>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/gpu/loop_limit.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/light_samples.h"
#include "penumbra/shadow/soft_shadow_volumes/edge_hierarchy.h"
#include "penumbra/shadow/soft_shadow_volumes/soft_shadow_volumes_gpu_testing.h"
#include "penumbra/shadow/soft_shadow_volumes/ssv_shared.h"

namespace penumbra {
namespace ssv {
namespace {
int g_test_samples_per_dispatch = 0;  // SsvSamplesPerDispatchForTesting; 0: none
}  // namespace
SsvSamplesPerDispatchForTesting::SsvSamplesPerDispatchForTesting(int samples) { g_test_samples_per_dispatch = samples; }
SsvSamplesPerDispatchForTesting::~SsvSamplesPerDispatchForTesting() { g_test_samples_per_dispatch = 0; }
}  // namespace ssv

namespace {

using shader::SsvEdge;
using shader::SsvNode;

// The deepest a walk of the hierarchy goes (its stack holds at most one entry more).
uint32_t hierarchy_depth(const std::vector<BvhNode>& nodes) {
  if (nodes.empty()) return 0;
  std::vector<uint32_t> depth(nodes.size(), 1);
  uint32_t most = 1;
  for (size_t k = 0; k < nodes.size(); ++k) {  // children come after their parent
    most = std::max(most, depth[k]);
    if (!nodes[k].leaf()) depth[nodes[k].first] = depth[nodes[k].first + 1] = depth[k] + 1;
  }
  return most;
}

class SoftShadowVolumesGpu final : public GpuShadowMethod {
 public:
  SoftShadowVolumesGpu() {
    if (ssv::g_test_samples_per_dispatch > 0) split_.start_with(ssv::g_test_samples_per_dispatch);
  }

  void prepare(const ShadowContext& ctx, GpuFrame& frame) override {
    stats_.prepare_count++;
    gpu::Device& device = *frame.device;
    ssv::EdgeHierarchy h;
    h.build(*ctx.scene, *ctx.light);
    const std::vector<BvhNode>& bnodes = h.bvh.nodes();
    if (hierarchy_depth(bnodes) + 2 > shader::kSsvStack)
      throw Error("ssv-rt on the GPU: the silhouette edges' hierarchy is {} levels deep (at most {})",
                  hierarchy_depth(bnodes), shader::kSsvStack - 2);
    std::vector<SsvNode> nodes(bnodes.size());
    for (size_t k = 0; k < bnodes.size(); ++k) {
      const ssv::NodeFacing& f = h.node_facing[k];
      SsvNode& n = nodes[k];
      n.lo = bnodes[k].bounds.lo;
      n.hi = bnodes[k].bounds.hi;
      n.first = bnodes[k].first;
      n.count = bnodes[k].count;
      n.axis = f.axis;
      n.spread = f.spread;
      n.centre = f.centre;
      n.half_diagonal = f.half_diagonal;
      n.h_lo = f.h_lo;
      n.h_hi = f.h_hi;
      n.cullable = f.cullable ? 1u : 0u;
    }
    std::vector<SsvEdge> edges(h.edges.size());
    for (size_t i = 0; i < edges.size(); ++i) {
      const ssv::SilhouetteEdge& e = h.edges[i];
      const ssv::EdgeFacing& f = h.facing[i];
      SsvEdge& g = edges[i];
      g.a = e.a;
      g.b = e.b;
      g.triangles = e.triangles;
      g.w0 = e.w[0];
      g.w1 = e.triangles == 2 ? e.w[1] : e.w[0];
      g.n0 = f.n[0];
      g.d0 = f.d[0];
      g.scale0 = f.scale[0];
      g.n1 = f.n[1];
      g.d1 = f.d[1];
      g.scale1 = f.scale[1];
    }
    nodes_ = gpu::make_buffer<SsvNode>(device, nodes, "ssv-rt's edge hierarchy");
    edges_ = gpu::make_buffer<SsvEdge>(device, edges, "ssv-rt's silhouette edges");
    node_count_ = static_cast<uint32_t>(nodes.size());
    std::vector<uint32_t> closed(std::max<size_t>(1, ctx.scene->objects.size()), 0);
    for (size_t o = 0; o < ctx.scene->objects.size(); ++o) closed[o] = ctx.scene->objects[o].closed ? 1u : 0u;
    closed_ = gpu::make_buffer<uint32_t>(device, closed, "ssv-rt's closed objects");
    if (counters_.empty()) counters_ = gpu::Buffer(device, shader::kSsvCounters * 4, "ssv-rt's counters");
    stats_.extra["silhouette_edges"] = h.edges.size();
  }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    gpu::Device& device = *frame.device;
    const int n = std::max(1, ctx.light_samples);
    if (n > static_cast<int>(shader::kSsvMaxSamples))
      throw Error("ssv-rt on the GPU: --spp {} is more than the {} light samples a work group holds (render it with "
                  "--device cpu)",
                  n, shader::kSsvMaxSamples);
    // The CPU's samples (the same seed, light and frame) and its pyramid base.
    const LightSamples samples = make_light_samples(light, n, ctx.seed, ctx.light_index, ctx.frame);
    const ssv::PyramidBase base = ssv::pyramid_base(samples);
    std::vector<Vec3f> block(base.corners, base.corners + 4);
    block.push_back(base.centre);
    block.insert(block.end(), samples.points.begin(), samples.points.end());
    // A previous frame's kernels may still read the light block: run them first (uploads are
    // immediate, kernels recorded).
    frame.flush();
    gpu::ensure_buffer(device, light_, block.size() * sizeof(Vec3f), "ssv-rt's light samples");
    light_.upload(std::span<const Vec3f>(block));

    shader::SsvParams p{};
    p.scene = frame.scene->address();
    p.samples = frame.view_samples;
    p.visibility = out.visibility;
    p.nodes = nodes_.address();
    p.edges = edges_.address();
    p.light = light_.address();
    p.counters = counters_.address();
    p.closed = closed_.address();
    p.light_center = light.center;
    p.n = static_cast<uint32_t>(n);
    p.light_n = light.frame.n;
    p.slots = frame.slots;
    p.node_count = node_count_;
    p.canary = gpu::kLoopLimitCanary;
    // The light samples over as many dispatches as the driver's loop limit needs (each redoes the
    // walk for its share of the samples; the first writes V, the others add to it); the counters
    // and the two flags read back after each try: a thread cut short is retried with fewer
    // samples, a stack overflow is said, never a short result.
    uint32_t c[shader::kSsvCounters] = {};
    split_.execute(
        n, "ssv-rt", device.info().name,
        [&](int first, int count) {
          if (first == 0) frame.commands->fill(counters_, 0);
          frame.commands->stage("evaluate");
          p.first_sample = static_cast<uint32_t>(first);
          p.sample_count = static_cast<uint32_t>(count);
          frame.commands->dispatch("ssv_evaluate", uint64_t{frame.slots} * 64, p);
        },
        [&] {
          frame.flush();
          counters_.download(c, sizeof(c));
          return c[shader::kSsvLoopCut] != 0;
        });
    if (c[shader::kSsvStackFull] != 0)
      throw Error("ssv-rt on the GPU: the hierarchy walk's stack overflowed");
    stats_.extra["dispatches_per_frame"] = (n + split_.items_per_dispatch() - 1) / split_.items_per_dispatch();
    stats_.rays_traced += c[shader::kSsvGroups];
    stats_.extra["light_samples"] = n;
    add(stats_.extra["edge_tests"], c[shader::kSsvEdgeTests]);
    add(stats_.extra["edge_updates"], c[shader::kSsvEdgeUpdates]);
    add(stats_.extra["reference_crossings"], c[shader::kSsvCrossings]);
    add(stats_.extra["sample_groups"], c[shader::kSsvGroups]);
    uint64_t bytes = 0;
    for (const gpu::Buffer* b : {&nodes_, &edges_, &closed_, &counters_, &light_}) bytes += b->bytes();
    stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, bytes);
  }

 private:
  template <class J>
  static void add(J& j, uint64_t v) {
    j = (j.is_number() ? j.template get<uint64_t>() : uint64_t{0}) + v;
  }

  gpu::Buffer nodes_, edges_, closed_, counters_, light_;
  gpu::LoopLimitSplit split_;  // light samples per dispatch (lavapipe's loop limit)
  uint32_t node_count_ = 0;
};

// One light's instance on the device: the potential silhouette edges (at most 3/2 per triangle
// of a closed mesh, ssv::kEdgesPerTriangle; a triangle soup up to twice that) and their
// hierarchy's nodes, a flag per object, the counters, the pyramid base and the light samples.
MemoryEstimate memory(const ParamSet&, const MemoryQuery& q) {
  MemoryTally tally;
  const uint64_t edges = static_cast<uint64_t>(2 * ssv::kEdgesPerTriangle * static_cast<double>(q.triangles));
  tally.add(edges * sizeof(SsvEdge) + TriangleBvh::node_bound(edges, ssv::EdgeHierarchy::kLeafSize) * sizeof(SsvNode),
            kTrianglesSetting);
  tally.add((shader::kSsvLightCorners + static_cast<uint64_t>(std::max(1, q.light_samples))) * sizeof(Vec3f),
            kLightSamplesSetting);
  tally.add(shader::kSsvCounters * 4 + q.triangles * 4, kTrianglesSetting);  // the counters; a flag per object (at most one a triangle)
  return tally.estimate();
}

const GpuMethodRegistration registration(
    {"ssv-rt", [](const ParamSet&) { return std::make_unique<SoftShadowVolumesGpu>(); }, memory});

}  // namespace
}  // namespace penumbra
