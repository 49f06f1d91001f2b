// `afsm-hard` and `afsm` on the GPU (sintorn2008 §3 and §4, as its authors ran them in CUDA): the
// view samples listed at the texels of a view from the light's centre (counts, a prefix sum, a
// scatter: kernels/afsm_*_list_*.comp, gpu/scan_gpu.h), every caster's conservative coverage of that
// view in compute (afsm_*_casters.comp sets up and counts texel rows: the triangle for afsm-hard,
// its influence region for afsm; afsm_*_cover.comp walks them), and per (listed sample, caster)
// the tests of alias_free_shared.h that the CPU version runs (afsm_hard_blocks; afsm_pair_lines
// and afsm_above per light sample; afsm per depth slab of the lists, as the CPU version: the
// casters and cover passes once per slab, each with its own far plane). The view is fitted on the device
// (shadow_map::fit_light_centre_view), the list buffer sized from the counting pass (grown when a
// frame lists more entries than it holds: nothing is ever dropped). docs/methods/alias-free.md,
// "On the GPU".
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <optional>
#include <span>
#include <vector>

#include "penumbra/core/error.h"

#include "penumbra/gpu/scan_gpu.h"
#include "penumbra/raster/raster_shared.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/shadow/alias_free/alias_free_gpu_testing.h"
#include "penumbra/shadow/alias_free/alias_free_shared.h"
#include "penumbra/shadow/alias_free/sample_masks.h"
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
// afsm_counters.glsl finds the counters right after the view.
static_assert(sizeof(shader::RasterView) == 160);

// What both methods share: the view fitted on the device and uploaded for the kernels, and the
// growth rule of the list buffer.
class AliasFreeGpuBase : public GpuShadowMethod {
 public:
  explicit AliasFreeGpuBase(const ParamSet& p) : view_{p.get_int("resolution"), p.get_float("max_fov")} {}

  void prepare(const ShadowContext& ctx, GpuFrame& frame) override {
    stats_.prepare_count++;
    casters_bounds_ = ctx.scene->bounds();
    reach_ = shadow_map::shadow_reach(*ctx.scene, *ctx.light);
    if (range_.empty()) {
      range_ = gpu::Buffer(*frame.device, sizeof(shader::GpuReceiverRange), "afsm's receiver range");
      view_buffer_ = gpu::Buffer(*frame.device, kViewBufferBytes, "afsm's light view");
      capacity_ = afsm::g_test_capacity;
    }
  }

 protected:
  // §4.3 "Parametrization": the view fitted to the receivers (the CPU fits it to the listed
  // points, which lie within 3e-5 of them: the texels differ at most at the window's border),
  // uploaded to view_buffer_ (zeros without one: then no view sample is in front of the light)
  // after the fit's flush, when no recorded kernel still reads the previous view.
  std::optional<LightView> fit(const ShadowContext& ctx, GpuFrame& frame) {
    // The counters add up over the frames until collect_stats().
    // (The counters, and the slabs' record with its cover_rows counter.)
    if (!counting_) frame.commands->fill(view_buffer_, 0, kCountersOffset, kViewBufferBytes - kCountersOffset);
    counting_ = true;
    std::optional<LightView> view = shadow_map::fit_light_centre_view(ctx, frame, view_, casters_bounds_, reach_, range_);
    const shader::RasterView rv = view ? view->shared() : shader::RasterView{};
    view_buffer_.upload(&rv, sizeof(rv));
    return view;
  }
  // Room for `listed` list positions of `bytes_each` bytes in listed_ (at most `most` are ever
  // needed): half as much again when it grows (fewer reallocations as the view moves).
  void grow_lists(gpu::Device& device, uint32_t listed, uint32_t most, uint64_t bytes_each) {
    if (listed > capacity_) {
      capacity_ = std::max(listed, std::min(capacity_ + capacity_ / 2, most));
      ++afsm::g_test_grows;
    }
    gpu::ensure_buffer(device, listed_, uint64_t{capacity_} * bytes_each, "afsm's lists");
  }
  // Each method's kernels, by pass.
  struct Kernels {
    const char* list_count;    // per view-sample slot: its entries' texels counted
    const char* casters;       // per triangle: its coverage set up, its rows counted
    const char* list_scatter;  // per view-sample slot: its entries listed
    const char* cover;         // per (caster, covered row): the tests
    const char* cover_stage;   // the CPU version's name of that phase
    const char* resolve;       // per view-sample slot: V
  };
  // What the counting passes found: list entries and covered rows.
  struct Totals {
    uint32_t listed = 0, rows = 0;
  };
  // The view's buffer: the RasterView, the cover kernels' counters and (afsm) the depth slabs.
  static constexpr uint64_t kCountersOffset = sizeof(shader::RasterView);
  static constexpr uint64_t kSlabsOffset = kCountersOffset + sizeof(shader::AfsmCounters);
  static constexpr uint64_t kViewBufferBytes = kSlabsOffset + sizeof(shader::AfsmSlabs);

  // The buffers both methods size the same way: per entry (`entries`) a state and a point, per
  // texel a start and a cursor, per triangle a caster record of `caster_bytes`, a row count and a
  // polygon of `polygon_vertices`; the parameters' addresses of them.
  template <class Params>
  void ensure_common(gpu::Device& device, uint32_t entries, uint32_t texels, uint32_t triangles, uint64_t caster_bytes,
                     uint64_t polygon_vertices, Params& p) {
    gpu::ensure_buffer(device, state_, uint64_t{entries} * 4, "afsm's entry states");
    gpu::ensure_buffer(device, points_, uint64_t{entries} * sizeof(Vec3f), "afsm's listed points");
    gpu::ensure_buffer(device, first_, (uint64_t{texels} + 1) * 4, "afsm's list starts");
    gpu::ensure_buffer(device, cursor_, uint64_t{texels} * 4, "afsm's list cursors");
    gpu::ensure_buffer(device, casters_, uint64_t{triangles} * caster_bytes, "afsm's casters");
    gpu::ensure_buffer(device, rows_, (uint64_t{triangles} + 1) * 4, "afsm's caster rows");
    gpu::ensure_buffer(device, polygons_, uint64_t{triangles} * polygon_vertices * sizeof(Vec2f), "afsm's caster polygons");
    p.view = view_buffer_.address();
    p.state = state_.address();
    p.points = points_.address();
    p.first = first_.address();
    p.cursor = cursor_.address();
    p.casters = casters_.address();
    p.rows = rows_.address();
    p.polygons = polygons_.address();
    p.triangles = triangles;
  }
  // §3.1: the entries counted per list key (`keys` of them: afsm-hard's texels, afsm's slabs ×
  // texels) by `count_keys`, which `list_count` and the kernels between them leave in first_ and
  // the entries' states; then scanned. Recorded, not run.
  template <class Params, class CountKeys>
  void record_lists(GpuFrame& frame, uint32_t keys, Params& p, const Kernels& k, CountKeys&& count_keys) {
    gpu::CommandList& cl = *frame.commands;
    cl.stage("lists");
    cl.fill(first_, 0);
    cl.fill(cursor_, 0);
    p.count = frame.slots;
    cl.dispatch(k.list_count, frame.slots, p);
    count_keys();
    if (keys > 0) list_scan_.exclusive(cl, first_.address(), first_.address(), keys);
  }
  // §3.2 / §4.1: each caster's coverage set up and its covered rows counted, then scanned.
  template <class Params>
  void record_casters(gpu::CommandList& cl, Params& p, const Kernels& k) {
    cl.stage("casters");
    p.count = p.triangles;
    cl.dispatch(k.casters, p.triangles, p);
    row_scan_.exclusive(cl, rows_.address(), rows_.address(), p.triangles);
  }
  // Runs what was recorded and reads back the lists' total (t.listed) and, with `rows`, the
  // casters' (t.rows): they size the lists and the cover pass.
  Totals read_totals(GpuFrame& frame, uint32_t keys, uint32_t triangles, bool rows) {
    frame.flush();
    Totals t;
    first_.download(&t.listed, 4, uint64_t{keys} * 4);
    if (rows && triangles > 0) rows_.download(&t.rows, 4, uint64_t{triangles} * 4);
    return t;
  }
  // The entries scattered into their lists (p.listed sized for t.listed), each caster over the
  // lists of its covered rows (`cover_passes` records those passes), V per slot.
  template <class Params, class CoverPasses>
  void cover(GpuFrame& frame, Totals t, Params& p, const Kernels& k, CoverPasses&& cover_passes) {
    gpu::CommandList& cl = *frame.commands;
    if (t.listed > 0) {
      cl.stage("lists");
      p.count = frame.slots;
      cl.dispatch(k.list_scatter, frame.slots, p);
      cover_passes();
    }
    cl.stage("resolve");
    p.count = frame.slots;
    cl.dispatch(k.resolve, frame.slots, p);
  }

  // The cover kernels' counters (the CPU version's texel_visits and sample_tests).
  void collect_stats() override {
    if (!counting_) return;
    shader::AfsmCounters c{};
    view_buffer_.download(&c, sizeof(c), kCountersOffset);
    counting_ = false;
    stats_.texels_visited += c.texel_visits;
    stats_.extra["texel_visits"] = c.texel_visits;
    stats_.extra["sample_tests"] = c.sample_tests;
  }

  void report_view(const std::optional<LightView>& view, Totals t) {
    stats_.extra["map_width"] = view ? view->width() : 0;
    stats_.extra["map_height"] = view ? view->height() : 0;
    stats_.extra["listed_samples"] = t.listed;
    stats_.extra["cover_rows"] = t.rows;
  }

  shadow_map::ViewParams view_;
  Bounds3f casters_bounds_;
  ShadowRegion reach_;  // shadow_map::shadow_reach
  uint32_t capacity_ = 0;  // list positions listed_ holds
  bool counting_ = false;  // a frame ran since the last collect_stats()
  gpu::Buffer range_, view_buffer_, listed_;
  gpu::Buffer state_, points_, first_, cursor_, casters_, rows_, polygons_;
  // The lists' and the casters' rows' offsets (one scan each: they are recorded in one list).
  gpu::GpuScan list_scan_, row_scan_;
};

class AliasFreeHardGpu final : public AliasFreeGpuBase {
 public:
  using AliasFreeGpuBase::AliasFreeGpuBase;

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    gpu::Device& device = *frame.device;
    const std::optional<LightView> view = fit(ctx, frame);
    const uint32_t texels = view ? static_cast<uint32_t>(view->width() * view->height()) : 0;
    const uint32_t triangles = view ? static_cast<uint32_t>(frame.scene->triangle_count()) : 0;
    static constexpr Kernels kKernels{"afsm_hard_list_count", "afsm_hard_casters",   "afsm_hard_list_scatter",
                                      "afsm_hard_cover",      "raster_center",       "afsm_hard_resolve"};
    shader::AfsmHardParams p{};
    ensure_common(device, frame.slots, texels, triangles, sizeof(AfsmHardCaster), kPolygonVertices, p);
    p.scene = frame.scene->address();
    p.samples = frame.view_samples;
    p.visibility = out.visibility;
    p.light_center = light.center;
    p.light_n = light.frame.n;
    // §3.1: the samples per texel; §3.2: the casters' covered rows.
    Totals t;
    record_lists(frame, texels, p, kKernels, [] {});
    if (view) {
      if (triangles > 0) record_casters(*frame.commands, p, kKernels);
      t = read_totals(frame, texels, triangles, true);
    }
    grow_lists(device, t.listed, frame.slots, sizeof(AfsmListed));  // a view sample is listed once
    p.listed = listed_.address();
    // §3.3: each caster over the lists of the texels it touches.
    cover(frame, t, p, kKernels, [&] {
      if (t.rows == 0) return;
      frame.commands->stage(kKernels.cover_stage);
      p.count = t.rows;
      frame.commands->dispatch(kKernels.cover, t.rows, p);
    });
    report_view(view, t);
    stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, device_bytes());
  }

 private:
  uint64_t device_bytes() const {
    uint64_t sum = 0;
    for (const gpu::Buffer* b : {&range_, &view_buffer_, &state_, &points_, &first_, &cursor_, &casters_, &rows_,
                                 &polygons_, &listed_})
      sum += b->bytes();
    return sum + list_scan_.device_bytes() + row_scan_.device_bytes();
  }
};

// One light's instance on the device: per view-sample slot its state and listed point, and a
// list position (a sample is listed at most once); per texel of the fitted view (resolution^2) a
// list start and a cursor; per triangle its caster record, row count and clipped polygon; the
// fitted range and the view.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  const ViewSize v = fitted_view_bound(p.get_int("resolution"));
  const uint64_t texels = static_cast<uint64_t>(v.width) * static_cast<uint64_t>(v.height);
  tally.add((2 * texels + 1) * sizeof(uint32_t) + gpu::GpuScan::scratch_bytes(texels), "resolution");
  tally.add(q.view_samples * (sizeof(uint32_t) + sizeof(Vec3f) + sizeof(AfsmListed)), kViewSamplesSetting);
  tally.add(q.triangles * (sizeof(AfsmHardCaster) + sizeof(uint32_t) + kPolygonVertices * sizeof(Vec2f)) +
                sizeof(uint32_t) + gpu::GpuScan::scratch_bytes(q.triangles),
            kTrianglesSetting);
  tally.add(sizeof(shader::GpuReceiverRange) + sizeof(shader::RasterView) + sizeof(shader::AfsmCounters) +
                sizeof(shader::AfsmSlabs),
            "resolution");
  return tally.estimate();
}

const GpuMethodRegistration registration(
    {"afsm-hard", [](const ParamSet& p) { return std::make_unique<AliasFreeHardGpu>(p); }, memory});

// ---------------------------------------------------------------------------------------
// afsm

using shader::AfsmSoftCaster;
using shader::AfsmSoftListed;

class AliasFreeSoftGpu final : public AliasFreeGpuBase {
 public:
  explicit AliasFreeSoftGpu(const ParamSet& p)
      : AliasFreeGpuBase(p),
        jitter_(p.get_bool("jitter")),
        lut_bins_(p.get_bool("lut") ? p.get_int("lut_resolution") : 0),
        slabs_(slab_count(p)) {}

  // The depth slabs a frame cuts its lists into (`slabs`, at most kAfsmMaxSlabs).
  static uint32_t slab_count(const ParamSet& p) {
    return static_cast<uint32_t>(std::clamp<int64_t>(p.get_int("slabs"), 1, shader::kAfsmMaxSlabs));
  }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    if (jitter_ && (light.shape == LightShape::Disk || light.shape == LightShape::Sphere))
      throw Error("afsm on the GPU: jitter=true is not supported (render it with --device cpu)");
    gpu::Device& device = *frame.device;
    // §4.2: the N light samples (the CPU's set: the same seed, light and frame), as bits.
    const afsm::LightSamples samples =
        afsm::make_light_samples(light, ctx.light_samples, ctx.seed, ctx.light_index, ctx.frame);
    const uint32_t n = static_cast<uint32_t>(samples.size());
    const uint32_t words = (n + 31) / 32;
    // A list position's masks: its blocked light samples and, where some caster stops only part
    // of the light, the samples such casters cover (their rays decide: afsm_soft_resolve).
    const uint32_t stride = ctx.scene->semi_transparent() ? 2 * words : words;
    // Uploads are immediate, the kernels recorded: the light block is written after fit()'s flush
    // has run everything recorded before (a previous progressive frame's kernels still read it).
    const std::optional<LightView> view = fit(ctx, frame);
    upload_light(device, samples, light, stride);
    const uint32_t texels = view ? static_cast<uint32_t>(view->width() * view->height()) : 0;
    const uint32_t triangles = view ? static_cast<uint32_t>(frame.scene->triangle_count()) : 0;
    const uint32_t entries = 2 * frame.slots;  // a split sample is listed once per side
    // A list per (depth slab, texel); keys stay below the entry states' codes (64 slabs of an
    // 8192² view would not: fewer slabs change the work, never the result).
    const uint32_t slabs = static_cast<uint32_t>(
        std::min<uint64_t>(slabs_, (uint64_t{shader::kAfsmUncovered} - 1) / std::max<uint32_t>(texels, 1)));
    const uint32_t keys = slabs * texels;
    static constexpr Kernels kKernels{"afsm_soft_list_count", "afsm_soft_casters", "afsm_soft_list_scatter",
                                      "afsm_soft_cover",      "raster",            "afsm_soft_resolve"};
    shader::AfsmSoftParams p{};
    ensure_common(device, entries, keys, triangles, sizeof(AfsmSoftCaster), shader::kAfsmRegionVertices, p);
    p.scene = frame.scene->address();
    p.samples = frame.view_samples;
    p.visibility = out.visibility;
    p.light = light_.address();
    p.slabs = slabs;
    gpu::CommandList& cl = *frame.commands;
    // §3.1: the entries per texel, their depths' histogram, the slabs cut from it (equal counts, as
    // the CPU's split_by_depth), then the entries per (slab, texel) and each slab's far plane.
    cl.fill(view_buffer_, 0, kSlabsOffset + offsetof(shader::AfsmSlabs, far_bits),
            sizeof(shader::AfsmSlabs) - offsetof(shader::AfsmSlabs, far_bits));
    record_lists(frame, keys, p, kKernels, [&] {
      if (!view) return;
      cl.dispatch("afsm_soft_slabs", 256, p);
      cl.dispatch("afsm_soft_list_key", frame.slots, p);
    });
    if (view) cl.dispatch("afsm_soft_slab_bounds", uint64_t{slabs} * view->height(), p);
    Totals t;
    if (view) t = read_totals(frame, keys, triangles, false);
    grow_lists(device, t.listed, entries, sizeof(AfsmSoftListed));
    gpu::ensure_buffer(device, masks_, uint64_t{capacity_} * stride * 4, "afsm's sample masks");
    p.listed = listed_.address();
    p.masks = masks_.address();
    // Per slab, §4.1: the casters' influence regions on its far plane and their covered rows;
    // §4.2: each caster's masks over the slab's lists in its region. The masks are per list
    // position, so they gather over the slabs' passes; the cover pass is as long as the rows the
    // GPU counted (an indirect dispatch: no read-back per slab).
    cover(frame, t, p, kKernels, [&] {
      for (uint32_t slab = 0; slab < slabs && triangles > 0; ++slab) {
        p.slab = slab;
        record_casters(cl, p, kKernels);
        cl.dispatch("afsm_soft_cover_args", 1, p);
        cl.stage(kKernels.cover_stage);
        cl.dispatch_indirect(kKernels.cover, view_buffer_, kSlabsOffset + offsetof(shader::AfsmSlabs, cover_groups_x), p);
      }
    });
    report_view(view, t);
    stats_.extra["light_samples"] = n;
    stats_.extra["depth_slabs"] = slabs;
    uint64_t bytes = 0;
    for (const gpu::Buffer* b : {&range_, &view_buffer_, &listed_, &light_, &state_, &points_, &first_, &cursor_,
                                 &casters_, &rows_, &polygons_, &masks_})
      bytes += b->bytes();
    bytes += list_scan_.device_bytes() + row_scan_.device_bytes();
    stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, bytes);
  }

  // The bytes of the light block and its samples for n light samples.
  // The bytes of the light block, its samples and the table for n light samples and bins^2 cells.
  static uint64_t light_bytes(uint64_t n, int bins) {
    const uint64_t cells = static_cast<uint64_t>(bins) * static_cast<uint64_t>(bins);
    return sizeof(shader::AfsmSoftLight) + n * (sizeof(Vec2f) + sizeof(Vec3f)) +
           cells * 2 * static_cast<uint64_t>(afsm::mask_words(static_cast<int>(n))) * sizeof(uint64_t);
  }

 private:
  // The light block (AfsmSoftLight, far_bits 0: the list pass raises it), the samples and the
  // plane-mask table (§4.2; built by the CPU's PlaneMaskLut, none with lut=false).
  void upload_light(gpu::Device& device, const afsm::LightSamples& samples, const AreaLight& light, uint32_t stride) {
    const uint32_t n = static_cast<uint32_t>(samples.size());
    const afsm::PlaneMaskLut lut(samples.local, lut_bins_, lut_bins_);
    shader::AfsmSoftLight l{};
    l.c = samples.center;
    l.n = n;
    l.ls = samples.s * samples.radius;
    l.words = (n + 31) / 32;
    l.lt = samples.t * samples.radius;
    l.max_distance2 = lut.max_distance2();
    l.axis = light.frame.n;
    l.stride = stride;
    l.lo_x = l.lo_y = kInfinity;
    l.hi_x = l.hi_y = -kInfinity;
    for (Vec2f u : samples.local) {
      l.lo_x = std::min(l.lo_x, u.x), l.hi_x = std::max(l.hi_x, u.x);
      l.lo_y = std::min(l.lo_y, u.y), l.hi_y = std::max(l.hi_y, u.y);
    }
    l.max_distance = lut.max_distance();
    l.angle_bins = static_cast<uint32_t>(lut.angle_bins());
    l.distance_bins = static_cast<uint32_t>(lut.distance_bins());
    const std::span<const uint64_t> table = lut.cells();
    std::vector<uint8_t> bytes(light_bytes(n, lut.has_table() ? lut_bins_ : 0));
    uint8_t* at = bytes.data();
    std::memcpy(at, &l, sizeof(l));
    std::memcpy(at += sizeof(l), samples.local.data(), n * sizeof(Vec2f));
    std::memcpy(at += n * sizeof(Vec2f), samples.points.data(), n * sizeof(Vec3f));
    if (!table.empty()) std::memcpy(at + n * sizeof(Vec3f), table.data(), table.size_bytes());
    gpu::ensure_buffer(device, light_, bytes.size(), "afsm's light samples");
    light_.upload(bytes.data(), bytes.size());
    stats_.extra["lut_bytes"] = table.size_bytes();
  }

  // The slabs' covered rows (counted on the device) join the other counters.
  void collect_stats() override {
    if (counting_) {
      uint64_t rows = 0;
      view_buffer_.download(&rows, sizeof(rows), kSlabsOffset + offsetof(shader::AfsmSlabs, cover_rows));
      stats_.extra["cover_rows"] = rows;
    }
    AliasFreeGpuBase::collect_stats();
  }

  bool jitter_;
  int lut_bins_;  // lut_resolution, 0 with lut=false
  uint32_t slabs_;
  gpu::Buffer light_, masks_;
};

// One light's instance on the device: per view-sample slot two entries (a split sample is listed
// once per side), each a state, a listed point, a list position and an N-bit mask; per texel of
// the fitted view a list start and a cursor; per triangle its caster record, row count and region
// hull; the light samples and the plane-mask table, the fitted range and the view.
MemoryEstimate soft_memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  const ViewSize v = fitted_view_bound(p.get_int("resolution"));
  const uint64_t texels = static_cast<uint64_t>(v.width) * static_cast<uint64_t>(v.height);
  const uint64_t n = static_cast<uint64_t>(q.light_samples), words = (n + 31) / 32;
  const uint64_t keys = texels * AliasFreeSoftGpu::slab_count(p);  // a list per (slab, texel)
  tally.add((2 * keys + 1) * sizeof(uint32_t) + gpu::GpuScan::scratch_bytes(keys) + sizeof(shader::GpuReceiverRange) +
                sizeof(shader::RasterView) + sizeof(shader::AfsmCounters) + sizeof(shader::AfsmSlabs),
            "resolution");
  tally.add(2 * q.view_samples * (sizeof(uint32_t) + sizeof(Vec3f) + sizeof(AfsmSoftListed)), kViewSamplesSetting);
  // (Twice that where some caster stops only part of the light: the samples such casters cover.)
  tally.add(2 * q.view_samples * words * sizeof(uint32_t) * (q.semi_transparent ? 2 : 1), kLightSamplesSetting);
  tally.add(AliasFreeSoftGpu::light_bytes(n, p.get_bool("lut") ? p.get_int("lut_resolution") : 0), "lut_resolution");
  tally.add(q.triangles * (sizeof(AfsmSoftCaster) + sizeof(uint32_t) + shader::kAfsmRegionVertices * sizeof(Vec2f)) +
                sizeof(uint32_t) + gpu::GpuScan::scratch_bytes(q.triangles),
            kTrianglesSetting);
  return tally.estimate();
}

const GpuMethodRegistration soft_registration(
    {"afsm", [](const ParamSet& p) { return std::make_unique<AliasFreeSoftGpu>(p); }, soft_memory});

}  // namespace
}  // namespace penumbra
