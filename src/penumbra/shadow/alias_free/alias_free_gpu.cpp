// `afsm-hard` on the GPU (sintorn2008 §3, as its authors ran it in CUDA): the view samples listed
// at the texels of a view from the light's centre (counts, a prefix sum, a scatter:
// kernels/afsm_hard_list_*.comp, gpu/scan.h), every caster's conservative coverage of that view
// in compute (afsm_hard_casters.comp sets up and counts rows, afsm_hard_cover.comp walks them),
// and per (listed sample, caster) the test of alias_free_shared.h that the CPU version runs
// (afsm_hard_blocks). The view is fitted on the device (shadow_map::fit_light_centre_view), the
// list buffer sized from the counting pass (grown when a frame lists more samples than it holds:
// nothing is ever dropped). docs/methods/alias-free.md, "On the GPU".
#include <algorithm>
#include <optional>

#include "penumbra/gpu/scan.h"
#include "penumbra/raster/raster_shared.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/shadow/alias_free/alias_free_gpu_testing.h"
#include "penumbra/shadow/alias_free/alias_free_shared.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/shadow_map_common_gpu.h"

namespace penumbra {
namespace afsm {
namespace {
uint32_t g_test_capacity = 0;  // AfsmListCapacityForTesting: the first list capacity; 0: none
int g_test_grows = 0;
}  // namespace

AfsmListCapacityForTesting::AfsmListCapacityForTesting(uint32_t slots) {
  g_test_capacity = slots;
  g_test_grows = 0;
}
AfsmListCapacityForTesting::~AfsmListCapacityForTesting() { g_test_capacity = 0; }
int AfsmListCapacityForTesting::grows() const { return g_test_grows; }
}  // namespace afsm

namespace {

using shader::AfsmHardCaster;
using shader::AfsmListed;

constexpr uint32_t kPolygonVertices = shader::kRasterMaxClipVertices;

// `buffer` with room for at least `bytes` (reallocated, contents lost, when smaller).
void ensure(gpu::Device& device, gpu::Buffer& buffer, uint64_t bytes, const char* what) {
  if (buffer.empty() || buffer.bytes() < bytes) buffer = gpu::Buffer(device, std::max<uint64_t>(bytes, 16), what);
}

class AliasFreeHardGpu final : public GpuShadowMethod {
 public:
  explicit AliasFreeHardGpu(const ParamSet& p) : view_{p.get_int("resolution"), p.get_float("max_fov")} {}

  void prepare(const ShadowContext& ctx, GpuFrame& frame) override {
    stats_.prepare_count++;
    casters_bounds_ = ctx.scene->bounds();
    if (range_.empty()) {
      range_ = gpu::Buffer(*frame.device, sizeof(shader::GpuReceiverRange), "afsm's receiver range");
      view_buffer_ = gpu::Buffer(*frame.device, sizeof(shader::RasterView), "afsm's light view");
      capacity_ = afsm::g_test_capacity;
    }
  }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    gpu::Device& device = *frame.device;
    gpu::CommandList& cl = *frame.commands;
    // §4.3 "Parametrization": the view fitted to the receivers (the CPU fits it to the listed
    // points, which lie within 3e-5 of them: the texels differ at most at the window's border).
    const std::optional<LightView> view = shadow_map::fit_light_centre_view(ctx, frame, view_, casters_bounds_, range_);
    const shader::RasterView rv = view ? view->shared() : shader::RasterView{};
    view_buffer_.upload(&rv, sizeof(rv));
    const uint32_t texels = view ? static_cast<uint32_t>(view->width() * view->height()) : 0;
    const uint32_t triangles = view ? static_cast<uint32_t>(frame.scene->triangle_count()) : 0;
    ensure(device, state_, uint64_t{frame.slots} * 4, "afsm's view-sample states");
    ensure(device, points_, uint64_t{frame.slots} * sizeof(Vec3f), "afsm's listed points");
    ensure(device, first_, (uint64_t{texels} + 1) * 4, "afsm's list starts");
    ensure(device, cursor_, uint64_t{texels} * 4, "afsm's list cursors");
    ensure(device, casters_, uint64_t{triangles} * sizeof(AfsmHardCaster), "afsm's casters");
    ensure(device, rows_, (uint64_t{triangles} + 1) * 4, "afsm's caster rows");
    ensure(device, polygons_, uint64_t{triangles} * kPolygonVertices * sizeof(Vec2f), "afsm's caster polygons");
    ensure(device, listed_, uint64_t{capacity_} * sizeof(AfsmListed), "afsm's lists");

    shader::AfsmHardParams p{};
    p.scene = frame.scene->address();
    p.view = view_buffer_.address();
    p.samples = frame.view_samples;
    p.visibility = out.visibility;
    p.state = state_.address();
    p.points = points_.address();
    p.first = first_.address();
    p.cursor = cursor_.address();
    p.casters = casters_.address();
    p.rows = rows_.address();
    p.polygons = polygons_.address();
    p.light_center = light.center;
    p.light_n = light.frame.n;
    p.triangles = triangles;

    // §3.1: count the samples per texel, scan; the casters' coverage rows, scan.
    cl.stage("lists");
    cl.fill(first_, 0);
    cl.fill(cursor_, 0);
    p.count = frame.slots;
    cl.dispatch("afsm_hard_list_count", frame.slots, p);
    if (view) gpu::exclusive_scan(cl, first_.address(), texels);
    if (triangles > 0) {
      cl.stage("casters");
      p.count = triangles;
      cl.dispatch("afsm_hard_casters", triangles, p);
      gpu::exclusive_scan(cl, rows_.address(), triangles);
    }
    // The totals size what follows: the lists' buffer and the cover pass's threads.
    uint32_t listed = 0, rows = 0;
    if (view) {
      frame.flush();
      first_.download(&listed, 4, uint64_t{texels} * 4);
      if (triangles > 0) rows_.download(&rows, 4, uint64_t{triangles} * 4);
    }
    if (listed > capacity_) {
      // Half as much again (fewer reallocations as the view moves), never more than a slot per
      // view sample (each is listed at most once).
      capacity_ = std::max(listed, std::min(capacity_ + capacity_ / 2, frame.slots));
      ensure(device, listed_, uint64_t{capacity_} * sizeof(AfsmListed), "afsm's lists");
      ++afsm::g_test_grows;
    }
    p.listed = listed_.address();
    if (listed > 0) {
      cl.stage("lists");
      p.count = frame.slots;
      cl.dispatch("afsm_hard_list_scatter", frame.slots, p);
      if (rows > 0) {
        // §3.2-3.3: each caster over the lists of the texels it touches.
        cl.stage("raster_center");
        p.count = rows;
        cl.dispatch("afsm_hard_cover", rows, p);
      }
    }
    cl.stage("resolve");
    p.count = frame.slots;
    cl.dispatch("afsm_hard_resolve", frame.slots, p);

    stats_.extra["map_width"] = view ? view->width() : 0;
    stats_.extra["map_height"] = view ? view->height() : 0;
    stats_.extra["listed_samples"] = listed;
    stats_.extra["cover_rows"] = rows;
    stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, device_bytes());
  }

 private:
  uint64_t device_bytes() const {
    uint64_t sum = 0;
    for (const gpu::Buffer* b : {&range_, &view_buffer_, &state_, &points_, &first_, &cursor_, &casters_, &rows_,
                                 &polygons_, &listed_})
      sum += b->bytes();
    return sum;
  }

  shadow_map::ViewParams view_;
  Bounds3f casters_bounds_;
  uint32_t capacity_ = 0;  // list positions listed_ holds
  gpu::Buffer range_, view_buffer_, state_, points_, first_, cursor_, casters_, rows_, polygons_, listed_;
};

// One light's instance on the device: per view-sample slot its state and listed point, and a
// list position (a sample is listed at most once); per texel of the fitted view (resolution^2) a
// list start and a cursor; per triangle its caster record, row count and clipped polygon; the
// fitted range and the view.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  const ViewSize v = fitted_view_bound(p.get_int("resolution"));
  const uint64_t texels = static_cast<uint64_t>(v.width) * static_cast<uint64_t>(v.height);
  tally.add((2 * texels + 1) * sizeof(uint32_t), "resolution");
  tally.add(q.view_samples * (sizeof(uint32_t) + sizeof(Vec3f) + sizeof(AfsmListed)), kViewSamplesSetting);
  tally.add(q.triangles * (sizeof(AfsmHardCaster) + sizeof(uint32_t) + kPolygonVertices * sizeof(Vec2f)) +
                sizeof(uint32_t),
            kTrianglesSetting);
  tally.add(sizeof(shader::GpuReceiverRange) + sizeof(shader::RasterView), "resolution");
  return tally.estimate();
}

const GpuMethodRegistration registration(
    {"afsm-hard", [](const ParamSet& p) { return std::make_unique<AliasFreeHardGpu>(p); }, memory});

}  // namespace
}  // namespace penumbra
