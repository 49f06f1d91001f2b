// `mlsm` and `mtsm` on the GPU (xie2007 §4-§6; docs/methods/multilayer.md, "On the GPU"): the
// CPU versions' light-centre view, fitted on the device (three reductions over the view samples,
// a few bytes read back each, the view built by the CPU's code), their map rendered by the GPU
// rasterizer (mlsm: the k-layer map by peeling; mtsm: fragment lists, compressed per texel by the
// CPU's function), the shared min/max pyramid, and one thread per view sample tracing its light
// samples through them with the CPU's walk and leaf tests (multilayer_trace_shared.h). Kernels and
// buffers: multilayer_kernels_shared.h.
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "penumbra/core/error.h"
#include "penumbra/core/sampling.h"
#include "penumbra/gpu/loop_limit.h"
#include "penumbra/gpu/minmax_pyramid_gpu.h"
#include "penumbra/gpu/raster/gpu_rasterizer.h"
#include "penumbra/gpu/raster/object_culling.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/partitions/light_partitions_gpu.h"
#include "penumbra/shadow/multilayer/multilayer_kernels_shared.h"
#include "penumbra/shadow/multilayer/multilayer_map.h"
#include "penumbra/shadow/multilayer/multilayer_trace.h"
#include "penumbra/shadow/shadow_map_kernels_shared.h"

namespace penumbra {
namespace {

using shader::GpuReceiverRange;

constexpr uint32_t kSmallest = 0xffffffffu;  // a minimum's start (raster_order_bits)

float order_float(uint32_t bits) { return shader::raster_order_float(bits); }

// A reduced range back as the CPU's ShadowViewRange (empty when nothing was fitted).
ShadowViewRange view_range(const GpuReceiverRange& r) {
  ShadowViewRange range;
  if (r.fitted == 0) return range;
  range.x0 = order_float(r.x0);
  range.x1 = order_float(r.x1);
  range.y0 = order_float(r.y0);
  range.y1 = order_float(r.y1);
  range.z0 = order_float(r.z0);
  range.z1 = order_float(r.z1);
  return range;
}

// Records the reset of `count` ranges starting at `first` (minima to the largest bits).
void reset_ranges(gpu::CommandList& cl, gpu::Buffer& ranges, int first, int count) {
  for (int k = first; k < first + count; ++k) {
    const uint64_t base = static_cast<uint64_t>(k) * sizeof(GpuReceiverRange);
    cl.fill(ranges, 0, base, sizeof(GpuReceiverRange));
    for (uint64_t offset : {offsetof(GpuReceiverRange, x0), offsetof(GpuReceiverRange, y0), offsetof(GpuReceiverRange, z0)})
      cl.fill(ranges, kSmallest, base + offset, 4);
  }
}

// Uploads floats into `buffer`, grown to hold them (at least 16 bytes).
void upload_floats(gpu::Device& device, gpu::Buffer& buffer, const std::vector<float>& values, const char* what) {
  const uint64_t bytes = std::max<uint64_t>(16, values.size() * sizeof(float));
  gpu::ensure_buffer(device, buffer, bytes, what);
  if (!values.empty()) buffer.upload(values.data(), values.size() * sizeof(float));
}

// The fragments mtsm's lists have room for at first (0: the rasterizer's choice); tests lower it.
uint32_t first_fragment_capacity = 0;

class MultilayerGpu final : public GpuShadowMethod {
 public:
  MultilayerGpu(const ParamSet& p, bool transparent)
      : transparent_(transparent), settings_(multilayer::multilayer_settings(p, transparent)) {}

  void prepare(const ShadowContext& ctx, GpuFrame& frame) override {
    stats_.prepare_count++;
    gpu::Device& device = *frame.device;
    casters_ = ctx.scene->bounds();
    culling_.prepare(device, *ctx.scene);
    candidates_ = multilayer::caster_candidates(*ctx.scene, *ctx.light);
    std::vector<shader::MlPlane> planes;
    plane_of_.assign(candidates_.size(), -1);
    for (size_t i = 0; i < candidates_.size(); ++i) {
      const multilayer::CasterCandidate& c = candidates_[i];
      if (!c.needs_receiver_behind) continue;
      plane_of_[i] = static_cast<int>(planes.size());
      planes.push_back({c.n, c.d, c.side, c.tol});
    }
    planes_ = gpu::make_buffer<shader::MlPlane>(device, planes, "the multilayer map's planar casters");
    behind_ = gpu::Buffer(device, std::max<uint64_t>(16, planes.size() * sizeof(uint32_t)), "the planar casters' flags");
    n_planes_ = static_cast<uint32_t>(planes.size());
    if (!rasterizer_) {
      rasterizer_ = std::make_unique<gpu::GpuRasterizer>(device);
      receivers_ = gpu::Buffer(device, sizeof(shader::MlReceivers), "the multilayer map's receivers");
      ranges_ = gpu::Buffer(device, 3 * sizeof(GpuReceiverRange), "the multilayer map's receiver ranges");
      fit_block_ = gpu::Buffer(device, sizeof(shader::MlFitBlock), "the multilayer map's fit");
      trace_block_ = gpu::Buffer(device, sizeof(shader::MlTraceBlock), "the multilayer map's view");
      map_counters_ = gpu::Buffer(device, sizeof(shader::MlMapCounters), "the multilayer map's statistics");
      counters_ = gpu::Buffer(device, sizeof(shader::MlGpuCounters), "the multilayer traces' counters");
      trace_frame_ = gpu::Buffer(device, sizeof(shader::MlTraceFrame), "the multilayer traces' frame");
    }
    const std::vector<Vec3f> outline16 = ctx.light->outline(16);
    n_outline16_ = static_cast<uint32_t>(outline16.size());
    upload_floats(device, outline16_, multilayer::flat_points(outline16), "the light's outline");
    built_ = false;
  }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    gpu::CommandList& cl = *frame.commands;
    cl.stage("build");
    // The receivers, their bounds, and the planes some receiver lies behind.
    cl.fill(receivers_, 0);
    for (uint64_t offset : {offsetof(shader::MlReceivers, lo_x), offsetof(shader::MlReceivers, lo_y),
                            offsetof(shader::MlReceivers, lo_z)})
      cl.fill(receivers_, kSmallest, offset, 4);
    cl.fill(behind_, 0);
    shader::MlFitReceiversParams rp{};
    rp.samples = frame.view_samples;
    rp.state = receivers_.address();
    rp.planes = planes_.address();
    rp.behind = behind_.address();
    rp.light_center = light.center;
    rp.slots = frame.slots;
    rp.light_n = light.frame.n;
    rp.n_planes = n_planes_;
    cl.dispatch("multilayer_fit_receivers", frame.slots, rp);
    frame.flush();
    shader::MlReceivers r{};
    receivers_.download(&r, sizeof(r));
    const bool has_map = r.count > 0;
    if (has_map) {
      const Bounds3f rb{{order_float(r.lo_x), order_float(r.lo_y), order_float(r.lo_z)},
                        {order_float(r.hi_x), order_float(r.hi_y), order_float(r.hi_z)}};
      // Built again only when the receivers' bounds change (the CPU's rule).
      if (!(built_ && rb.lo == receiver_bounds_.lo && rb.hi == receiver_bounds_.hi)) build(ctx, frame, r.count, rb);
    }
    const int n = std::max(1, ctx.light_samples);
    const StratifiedGrid grid(n);
    shader::MlTraceFrame tf{};
    tf.seed = ctx.seed;
    tf.light_index = ctx.light_index;
    tf.frame = ctx.frame;
    tf.n = n;
    tf.grid_cols = grid.cols();
    tf.inv_cols = grid.inv_cols();
    tf.inv_rows = grid.inv_rows();
    gpu::ensure_buffer(*frame.device, sums_, uint64_t(frame.slots) * 8, "the traces' partial sums");
    tf.sums = sums_.address();
    frame.flush();  // nothing recorded may still read the frame's record
    trace_frame_.upload(&tf, sizeof(tf));
    shader::MlTraceParams tp{};
    tp.scene = frame.scene->address();
    tp.samples = frame.view_samples;
    tp.light = frame.light;
    tp.visibility = out.visibility;
    tp.block = trace_block_.address();
    tp.counters = counters_.address();
    tp.trace_frame = trace_frame_.address();
    tp.slots = frame.slots;
    tp.has_map = has_map ? 1u : 0u;
    tp.canary = gpu::kLoopLimitCanary;
    if (has_map) {
      tp.nodes = pyramid_.address();
      if (transparent_) {
        tp.map_a = lists_.offsets();
        tp.map_b = layer_counts_.address();
        tp.map_c = layers_.address();
      } else {
        tp.map_a = layered_.counts();
        tp.map_b = layered_.samples();
      }
    }
    // Every light sample in one dispatch, unless the driver's loop limit cut a thread short
    // (lavapipe, gpu/loop_limit.h): then traced again in shorter dispatches, learned once.
    cl.stage("trace");
    cl.fill(counters_, 0);
    split_.execute(
        n, transparent_ ? "mtsm" : "mlsm", frame.device->info().name,
        [&](int first, int count) {
          tp.first_sample = first;
          tp.sample_count = count;
          cl.dispatch(transparent_ ? "mtsm_trace" : "mlsm_trace", frame.slots, tp);
        },
        [&] {
          frame.flush();
          shader::MlGpuCounters c{};
          counters_.download(&c, sizeof(c));
          if (c.limited != 0) {
            cl.stage("trace");
            cl.fill(counters_, 0);
            return true;
          }
          totals_.rays += c.rays;
          totals_.nodes += c.nodes;
          totals_.texels += c.texels;
          totals_.tested += c.tested;
          totals_.hits += c.hits;
          totals_.unresolved += c.unresolved;
          return false;
        });
    counting_ = true;
    light_suffix_ = ctx.light_index == 0 ? "" : "_light" + std::to_string(ctx.light_index);
  }

  void collect_stats() override {
    if (!counting_) return;
    counting_ = false;
    const shader::MlGpuCounters c = totals_;
    totals_ = {};
    stats_.rays_traced += c.rays;
    stats_.texels_visited += c.texels;
    nlohmann::json e = build_extra_;
    const double rays = static_cast<double>(c.rays);
    e["trace"] = {{"rays", c.rays},
                  {"samples_per_dispatch", split_.items_per_dispatch()},
                  {"loop_limit_retries", split_.retries()},
                  {"nodes_per_ray", rays > 0 ? c.nodes / rays : 0.0},
                  {"texels_per_ray", rays > 0 ? c.texels / rays : 0.0},
                  {"layers_tested_per_ray", rays > 0 ? c.tested / rays : 0.0},
                  {"layer_hits", c.hits}};
    e["trace"]["unresolved_rays"] = c.unresolved;
    for (auto it = e.begin(); it != e.end(); ++it) stats_.extra[it.key() + light_suffix_] = it.value();
  }

 private:
  // The light-centre view for these receivers (light_centre_view, its per-receiver steps on the
  // device), then the map, its pyramid and the trace block (stage "build", already open).
  void build(const ShadowContext& ctx, GpuFrame& frame, uint32_t receivers, const Bounds3f& rb) {
    const AreaLight& light = *ctx.light;
    gpu::Device& device = *frame.device;
    gpu::CommandList& cl = *frame.commands;
    // caster_boxes: the planes some receiver lies behind, and every other object's box.
    std::vector<uint32_t> behind(n_planes_, 0);
    if (n_planes_) behind_.download(behind.data(), behind.size() * sizeof(uint32_t));
    std::vector<Bounds3f> boxes;
    for (size_t i = 0; i < candidates_.size(); ++i)
      if (plane_of_[i] < 0 || behind[plane_of_[i]]) boxes.push_back(candidates_[i].box);
    const std::span<const Bounds3f> fit_boxes =
        settings_.fit_shadowable ? std::span<const Bounds3f>(boxes) : std::span<const Bounds3f>();
    upload_floats(device, boxes_, multilayer::flat_boxes(boxes), "the multilayer map's caster boxes");

    // The fit from the light's centre: to the receivers a caster can shadow (or all).
    ShadowViewFit fit;
    fit.resolution = settings_.view.resolution;
    fit.max_fov = settings_.view.max_fov;
    const ShadowViewFrame centre = shadow_view_frame(light.center, light.frame.n, light.frame.t, casters_, {}, fit);
    shader::MlFitBlock block{};
    block.centre = centre.axes;
    block.light_center = light.center;
    block.light_n = light.frame.n;
    block.n_outline16 = n_outline16_;
    // Without fit_shadowable no box is tested: range 1 (every receiver) is the one fitted.
    block.n_boxes = settings_.fit_shadowable ? static_cast<uint32_t>(boxes.size()) : 0u;
    fit_block_.upload(&block, sizeof(block));
    gpu::ensure_buffer(device, keep_, uint64_t(frame.slots) * 4, "the multilayer map's kept receivers");
    reset_ranges(cl, ranges_, 0, 3);
    shader::MlFitParams fp{};
    fp.samples = frame.view_samples;
    fp.block = fit_block_.address();
    fp.ranges = ranges_.address();
    fp.keep = keep_.address();
    fp.outline16 = outline16_.address();
    fp.boxes = boxes_.address();
    fp.slots = frame.slots;
    cl.dispatch("multilayer_fit_shadowable", frame.slots, fp);
    frame.flush();
    GpuReceiverRange ranges[3];
    ranges_.download(ranges, sizeof(ranges));
    // shadowable_receivers keeps all when it keeps none (and fit_shadowable=false fits all).
    const bool kept_only = settings_.fit_shadowable && ranges[0].receivers > 0;
    const uint32_t fitted = kept_only ? ranges[0].receivers : ranges[1].receivers;
    multilayer::CentreView view;
    view.view = build_shadow_view(centre, view_range(ranges[kept_only ? 0 : 1]), casters_, fit);
    const multilayer::PushBackPlan plan = multilayer::plan_push_back(light, view.view, casters_, settings_.view, fit_boxes);
    view.half_fov_deg = plan.half_fov_deg;
    if (settings_.view.push_back) {
      // The fit from the pushed-back eye (eq. 4): the fitted receivers and their segments'
      // crossings of z_c, or the light's outline.
      view.push_back = plan.push_back;
      block.pushed = plan.frame.axes;
      block.z_c = plan.z_c;
      block.eye = plan.eye;
      block.dir = plan.dir;
      block.crossings = plan.crossings ? 1u : 0u;
      block.n_outline32 = static_cast<uint32_t>(plan.outline.size());
      block.kept_only = kept_only ? 1u : 0u;
      fit_block_.upload(&block, sizeof(block));
      upload_floats(device, outline32_, multilayer::flat_points(plan.outline), "the light's outline");
      fp.outline32 = outline32_.address();
      cl.dispatch("multilayer_fit_crossings", frame.slots, fp);
      frame.flush();
      GpuReceiverRange pushed{};
      ranges_.download(&pushed, sizeof(pushed), 2 * sizeof(GpuReceiverRange));
      ShadowViewRange range = view_range(pushed);
      if (!plan.crossings)
        for (Vec3f q : plan.outline) {
          float x, y, z;
          if (shader::shadow_view_project(plan.frame.axes, q, x, y, z)) range.add(x, y, z);
        }
      view.view = build_shadow_view(plan.frame, range, casters_, plan.fit);
      view.segments_held_beyond = multilayer::segments_held_beyond(plan, view.view, true);
    }
    view_ = view;

    // The map (stage "build" goes on in the rasterizer's submits), its level 0 and pyramid.
    const LightView& v = view_.view;
    const int w = v.width(), h = v.height();
    const uint64_t texels = static_cast<uint64_t>(w) * static_cast<uint64_t>(h);
    shader::MlTraceBlock tb{};
    tb.view = v.shared();
    pyramid_.resize(device, w, h, "the multilayer map's pyramid");
    tb.levels = pyramid_.levels_address();
    tb.width = w;
    tb.height = h;
    tb.k = settings_.layers;
    tb.level_count = pyramid_.levels();
    trace_block_.upload(&tb, sizeof(tb));
    shader::MlMapParams mp{};
    mp.block = trace_block_.address();
    mp.nodes = pyramid_.address();
    mp.counters = map_counters_.address();
    mp.texels = static_cast<uint32_t>(texels);
    mp.unknown_beyond_full = settings_.trace_unresolved ? 1u : 0u;
    cl.fill(map_counters_, 0);
    cl.fill(map_counters_, kSmallest, offsetof(shader::MlMapCounters, z_min_bits), 4);
    float z_min = kInfinity;
    // The objects wholly outside the fitted view are not rasterized (gpu/raster/object_culling.h).
    uint64_t culled = 0;
    const uint64_t flags = culling_.flags_for(v, &culled);
    stats_.add_count("culled_triangles", culled);
    if (!transparent_) {
      LayerOptions options;
      options.layers = settings_.layers;
      rasterizer_->layered_depth_map(cl, frame.flush, "build", *frame.scene, v, options, &layered_, flags);
      z_min = layered_.z_min();
      mp.map_a = layered_.counts();
      mp.map_b = layered_.samples();
      cl.stage("build");
      cl.fill(map_counters_, 0);
      cl.fill(map_counters_, kSmallest, offsetof(shader::MlMapCounters, z_min_bits), 4);
      cl.dispatch("mlsm_layer_ranges", texels, mp);
    } else {
      if (first_fragment_capacity) rasterizer_->set_fragment_capacity_for_testing(first_fragment_capacity);
      rasterizer_->fragment_lists(cl, frame.flush, "build", *frame.scene, v, RasterFilter{}, &lists_, flags);
      // A texel never has more layers than fragments: its layers go where its list starts.
      const uint64_t room = std::max<uint64_t>(1, lists_.capacity()) * sizeof(shader::TransparentLayer);
      gpu::ensure_buffer(device, layers_, room, "the transparent map's layers");
      gpu::ensure_buffer(device, layer_counts_, texels * 4, "the transparent map's layer counts");
      mp.map_a = lists_.offsets();
      mp.map_b = lists_.fragments();
      mp.map_c = layer_counts_.address();
      mp.map_d = layers_.address();
      mp.error = settings_.compression.error;
      mp.resets = settings_.compression.resets;
      mp.zero = settings_.compression.zero;
      cl.stage("build");
      cl.fill(map_counters_, 0);
      cl.fill(map_counters_, kSmallest, offsetof(shader::MlMapCounters, z_min_bits), 4);
      cl.dispatch("mtsm_compress", texels, mp);
    }
    pyramid_.build(cl);
    frame.flush();
    shader::MlMapCounters mc{};
    map_counters_.download(&mc, sizeof(mc));
    if (transparent_) z_min = mc.z_min_bits == kSmallest ? kInfinity : order_float(mc.z_min_bits);
    // z_thresh in camera space (xie2007 §6.1), as the CPU resolves it.
    multilayer::TraceParams params;
    params.self_bias = settings_.self_bias;
    params.open_self_bias = settings_.open_self_bias;
    params.stop_below = settings_.stop_below;
    params.near_field = settings_.near_field;
    params.light_width = shader::near_field_light_width(light.area());
    const multilayer::TraceParams resolved =
        multilayer::resolve_trace_params(params, v, z_min, settings_.z_thresh, settings_.z_thresh_texels);
    multilayer::TraceSetup setup = multilayer::make_trace_setup(v, z_min, resolved);
    setup.segments_held_beyond = view_.segments_held_beyond;
    tb.setup = multilayer::shared_trace_setup(setup, z_min);
    trace_block_.upload(&tb, sizeof(tb));
    receiver_bounds_ = rb;
    built_ = true;

    const uint64_t bytes = device_bytes();
    stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, bytes);
    build_extra_ = {{"map",
                     {{"width", w},
                      {"height", h},
                      {"covered_texels", mc.covered},
                      {"layers", mc.layers},
                      {"layers_per_covered_texel", mc.covered ? double(mc.layers) / double(mc.covered) : 0.0},
                      {"max_layers_in_a_texel", mc.max_layers},
                      {"bytes", bytes},
                      {"push_back", view_.push_back},
                      {"receivers", receivers},
                      {"receivers_fitted", fitted},
                      {"half_fov_degrees", view_.half_fov_deg},
                      {"z_min", z_min},
                      {"z_thresh", resolved.z_thresh}}},
                    {"raster_attempts", rasterizer_->attempts()}};
    if (transparent_) build_extra_["map"]["fragments"] = lists_.total();
  }

  uint64_t device_bytes() const {
    uint64_t b = pyramid_.device_bytes();
    if (transparent_)
      b += lists_.device_bytes() + layers_.bytes() + layer_counts_.bytes();
    else
      b += layered_.device_bytes();
    return b;
  }

  bool transparent_;
  multilayer::MultilayerSettings settings_;
  Bounds3f casters_, receiver_bounds_;
  std::vector<multilayer::CasterCandidate> candidates_;
  std::vector<int> plane_of_;  // per candidate: its plane's index, or -1 (always a caster)
  uint32_t n_planes_ = 0, n_outline16_ = 0;
  multilayer::CentreView view_;
  bool built_ = false;
  bool counting_ = false;
  std::string light_suffix_;
  // Light samples per dispatch: all, unless the driver limits one invocation's loops (lavapipe).
  gpu::LoopLimitSplit split_;
  shader::MlGpuCounters totals_{};
  nlohmann::json build_extra_ = nlohmann::json::object();
  std::unique_ptr<gpu::GpuRasterizer> rasterizer_;
  gpu::ObjectCulling culling_;  // the objects wholly outside the fitted view are not rasterized
  gpu::GpuLayeredDepthMap layered_;
  gpu::GpuFragmentLists lists_;
  gpu::GpuMinMaxPyramid pyramid_;
  gpu::Buffer planes_, behind_, receivers_, ranges_, fit_block_, keep_, outline16_, outline32_, boxes_;
  gpu::Buffer trace_block_, map_counters_, counters_, layers_, layer_counts_, trace_frame_, sums_;
};

// One light's device memory: the map of a resolution^2 bound (mlsm: k layers a texel; mtsm: the
// fragment lists at their first capacity, two fragments a texel, and as many layers, which grow
// with the scene's depth complexity), its pyramid, the rasterizer's scratch, and per view sample a
// flag for the fit and the traces' partial sums.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q, bool transparent) {
  MemoryTally tally;
  const ViewSize v = fitted_view_bound(p.get_int("resolution"));
  const uint64_t texels = static_cast<uint64_t>(v.width) * static_cast<uint64_t>(v.height);
  uint64_t map = gpu::GpuMinMaxPyramid::bytes(v.width, v.height);
  if (transparent)
    map += gpu::GpuFragmentLists::bytes(v.width, v.height, 2 * texels) +
           2 * texels * sizeof(shader::TransparentLayer) + texels * 4;
  else
    map += gpu::GpuLayeredDepthMap::bytes(v.width, v.height, p.get_int("layers"));
  tally.add(map, "resolution");
  tally.add(gpu::GpuRasterizer::scratch_bytes(q.triangles, v.width, v.height), kTrianglesSetting);
  tally.add(q.view_samples * (sizeof(uint32_t) + 2 * sizeof(float)), kViewSamplesSetting);
  partitions::add_gpu_memory(tally, p, q);
  return tally.estimate();
}

const GpuMethodRegistration mlsm_registration(
    {"mlsm", [](const ParamSet& p) { return partitions::wrap_gpu(std::make_unique<MultilayerGpu>(p, false), p, p.get_int("resolution"), multilayer::partition_guards(p)); },
     [](const ParamSet& p, const MemoryQuery& q) { return memory(p, q, false); }});

const GpuMethodRegistration mtsm_registration(
    {"mtsm", [](const ParamSet& p) { return partitions::wrap_gpu(std::make_unique<MultilayerGpu>(p, true), p, p.get_int("resolution"), multilayer::partition_guards(p)); },
     [](const ParamSet& p, const MemoryQuery& q) { return memory(p, q, true); }});

}  // namespace

namespace multilayer {
void set_first_gpu_fragment_capacity_for_testing(uint32_t fragments) { first_fragment_capacity = fragments; }
}  // namespace multilayer

}  // namespace penumbra
