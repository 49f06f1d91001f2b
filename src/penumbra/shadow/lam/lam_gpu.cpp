// `lam` on the GPU (agrawala2000 §4; issue 29): the layered attenuation map built on the device
// from the CPU version's light samples, kept while the light and the geometry stay (a camera move
// costs only the display, as on the CPU), and displayed by one lookup kernel.
//
// Precompute (stage "precompute"), per batch of light samples:
//   1. their depth maps, rendered many at once by the GPU rasterizer's batch mode
//      (gpu/raster/gpu_batch_rasterizer.h) from the CPU's sample views (lam::sample_view), the
//      triangles of closed meshes that face away from the whole light culled as the CPU culls
//      them; agrawala2000 rendered them with the graphics hardware;
//   2. the warp (eq. 3) and the insertion into the LDI at the light centre, the CPU's order and
//      arithmetic (lam_shared.h), so the layers are the CPU's.
//      Per sample, kernels/lam_scatter.comp warps each pixel and lists it in the 4 texels it
//      splats into (a full list sends its texel back to the map itself), then
//      kernels/lam_insert.comp has each texel of the LDI merge its splats in the CPU's order.
// Then kernels/lam_finalize.comp sorts each texel's layers and packs them; the build storage is
// freed. Display (stage "display"): kernels/lam_display.comp, lam_shared.h's lookup, the CPU's.
// The frame (region, reference view, outline) is built on the host by the CPU's code. Same
// parameters as lam.cpp's table.
#include <algorithm>

#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"
#include "penumbra/gpu/raster/gpu_batch_rasterizer.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/lam/attenuation_map.h"
#include "penumbra/shadow/lam/lam_gpu.h"
#include "penumbra/shadow/lam/lam_kernels_shared.h"

namespace penumbra {
namespace {

using shader::LamBuildLayer;
using shader::LamCounters;
using shader::LamSampleCounts;
using shader::LamSampleView;
using shader::LamSplatEntry;

// Splat-list slots per LDI texel: a light sample sends a texel about 4 splats (each pixel splats
// into 4 texels), more where a surface is more foreshortened in the LDI than in the sample's view.
constexpr uint32_t kListSlots = 12;
uint32_t g_list_slots_for_testing = 0;

// The slots for an LDI of `texels` texels: kListSlots, fewer where that would outgrow the batch
// budget (a texel whose list is full gathers instead: any number is right, fewer is slower).
uint32_t list_slots(uint64_t texels) {
  if (g_list_slots_for_testing > 0) return g_list_slots_for_testing;
  const uint64_t fit = gpu::GpuBatchRasterizer::batch_budget() / std::max<uint64_t>(1, texels * sizeof(LamSplatEntry));
  return static_cast<uint32_t>(std::clamp<uint64_t>(fit, 1, kListSlots));
}

// The texels of the LDI (at most resolution^2) and of one light sample's view.
uint64_t ldi_texels(int resolution) { return static_cast<uint64_t>(resolution) * static_cast<uint64_t>(resolution); }
uint64_t sample_view_texels(int resolution) {
  const uint64_t side = lam::sample_view_side_bound(resolution);
  return side * side;
}

class LayeredAttenuationMapsGpu final : public GpuShadowMethod {
 public:
  explicit LayeredAttenuationMapsGpu(const ParamSet& p)
      : options_(lam::build_options(p)),
        bilinear_(lam::display_filter(p) == lam::Filter::Bilinear),
        trace_unresolved_(p.get_string("unresolved") == "trace"),
        trace_spread_(static_cast<float>(p.get_float("trace_spread"))) {}

  void prepare(const ShadowContext& ctx, GpuFrame& frame) override {
    stats_.prepare_count++;
    gpu::Device& device = *frame.device;
    gpu::CommandList& cl = *frame.commands;
    const Scene& scene = *ctx.scene;
    const AreaLight& light = *ctx.light;
    // The CPU's samples and frame (lam.cpp).
    const LightSampleSet set = lam::light_sample_set(ctx);
    const int n = set.size();
    const lam::BuildOptions options = lam::options_for_scene(options_, scene);
    const ShadowRegion region = fit_shadow_region(scene, light);
    map_ = lam::attenuation_map_frame(light, region, n, options);
    map_.set_unresolved(trace_unresolved_, trace_spread_);  // the view below carries it
    view_ = gpu::make_buffer<shader::LamMapView>(device, std::span(&map_.shared(), 1), "lam's view");
    std::vector<Vec3f> outline(map_.outline().begin(), map_.outline().end());
    if (outline.empty()) outline.push_back(Vec3f(0.0f));
    outline_ = gpu::make_buffer<Vec3f>(device, outline, "lam's light outline");
    points_ = gpu::make_buffer<Vec3f>(device, lam::light_points(light, set), "lam's light points");
    counters_ = gpu::Buffer(device, sizeof(LamCounters), "lam's counters");
    sample_counts_ = gpu::Buffer(device, n * sizeof(LamSampleCounts), "lam's per-sample counts");
    cl.stage("precompute");
    cl.fill(counters_, 0);
    cl.fill(sample_counts_, 0);
    layers_ = gpu::Buffer();
    ranges_ = gpu::Buffer();
    peak_bytes_ = 0;
    sample_texels_ = 0;
    if (!map_.empty()) build(ctx, frame, set);
    if (ranges_.empty()) {
      // An empty region: nothing to look up (the display kernel reads the flag only).
      ranges_ = gpu::Buffer(device, 16, "lam's texel ranges");
      layers_ = gpu::Buffer(device, 16, "lam's layers");
    }
    frame.flush();
    // What the CPU reports of its build (lam.cpp), from the device's counters.
    LamCounters c{};
    counters_.download(&c, sizeof(c));
    const std::vector<LamSampleCounts> per_sample = sample_counts_.download_vector<LamSampleCounts>(n);
    lam::BuildStats bs;
    for (int k = 0; k < n; ++k) {
      bs.layers += per_sample[k].layers;
      bs.nonempty_texels += per_sample[k].nonempty;
      bs.depth_complexity.emplace_back(
          k + 1, bs.nonempty_texels ? static_cast<double>(bs.layers) / bs.nonempty_texels : 0.0);
    }
    bs.max_depth = static_cast<int>(c.max_depth);
    bs.dropped = c.dropped;
    bs.splats = c.splats;
    bs.sample_texels = sample_texels_;
    extra_ = lam::build_statistics(bs, map_, n, ldi_bytes());
    extra_["triangles"] = {{"scene", scene.triangle_count()}};
  }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    gpu::CommandList& cl = *frame.commands;
    cl.stage("display");
    if (!counting_) cl.fill(counters_, 0, offsetof(LamCounters, texels), sizeof(LamCounters) - offsetof(LamCounters, texels));
    counting_ = true;
    shader::LamDisplayParams p{};
    p.scene = frame.scene->address();
    p.samples = frame.view_samples;
    p.visibility = out.visibility;
    p.layers = layers_.address();
    p.ranges = ranges_.address();
    p.outline = outline_.address();
    p.view = view_.address();
    p.counters = counters_.address();
    p.points = points_.address();
    p.point_count = static_cast<uint32_t>(points_.bytes() / sizeof(Vec3f));
    p.slots = frame.slots;
    p.bilinear = bilinear_ ? 1u : 0u;
    cl.dispatch("lam_display", frame.slots, p);
    // Stats are per frame (the renderer clears them), the LDI is not: report it every frame.
    stats_.memory_bytes = std::max<uint64_t>(peak_bytes_, ldi_bytes());
    suffix_ = ctx.light_index == 0 ? "" : "_light" + std::to_string(ctx.light_index);
    for (auto it = extra_.begin(); it != extra_.end(); ++it) stats_.extra[it.key() + suffix_] = it.value();
  }

  // The texels the display read and the points it traced, counted on the device.
  void collect_stats() override {
    if (!counting_) return;
    LamCounters c{};
    counters_.download(&c, sizeof(c));
    stats_.texels_visited += c.texels;
    stats_.rays_traced += c.rays;
    if (trace_unresolved_) stats_.extra["traced_samples" + suffix_] = c.traced;
    counting_ = false;
  }

 private:
  // The layers on the device: the build storage and counts, filled batch by batch, then packed.
  void build(const ShadowContext& ctx, GpuFrame& frame, const LightSampleSet& set) {
    gpu::Device& device = *frame.device;
    gpu::CommandList& cl = *frame.commands;
    const AreaLight& light = *ctx.light;
    const LightView& ref = map_.view();
    const uint64_t texels = static_cast<uint64_t>(ref.width()) * ref.height();
    const uint32_t K = static_cast<uint32_t>(options_.max_layers);
    gpu::Buffer build(device, texels * K * sizeof(LamBuildLayer), "lam's layers while building");
    gpu::Buffer counts(device, texels * sizeof(uint32_t), "lam's layer counts");
    cl.fill(counts, 0);
    // The light samples' views (the CPU's, lam::sample_view) and where their pixels warp to.
    const int n = set.size();
    const LightAxes axes = light_axes(light);
    const float delta = map_.shared().delta;
    std::vector<LightView> views(n);
    std::vector<LamSampleView> records(n);
    for (int i = 0; i < n; ++i) {
      const Vec3f q = light.sample_area(set.base()[i]);
      views[i] = lam::sample_view(axes, ref, q, &records[i].ox, &records[i].oy);
      const Vec3f d = q - axes.eye;
      records[i].bx = dot(d, axes.right) / delta;
      records[i].by = dot(d, axes.up) / delta;
      records[i].width = views[i].width();
      records[i].height = views[i].height();
      sample_texels_ += static_cast<uint64_t>(views[i].width()) * views[i].height();
    }
    // The triangles of closed meshes facing away from the whole light: lam.cpp's culling.
    gpu::RasterOutlineCull cull;
    cull.orientation = lam::closed_mesh_orientations(*ctx.scene);
    cull.outline = light.outline(32);
    gpu::GpuBatchRasterizer rasterizer(device);
    gpu::GpuDepthMapBatch batch;
    gpu::Buffer samples;
    const int per_batch = gpu::GpuBatchRasterizer::batch_size(frame.scene->triangle_count(),
                                                              sample_view_texels(options_.resolution), false, n,
                                                              gpu::GpuBatchRasterizer::batch_budget());
    const uint32_t slots = list_slots(texels);
    gpu::Buffer lists(device, texels * slots * sizeof(LamSplatEntry), "lam's splat lists");
    gpu::Buffer list_counts(device, texels * sizeof(uint32_t), "lam's splat list counts");
    cl.fill(list_counts, 0);
    for (int b0 = 0; b0 < n; b0 += per_batch) {
      const int count = std::min(per_batch, n - b0);
      rasterizer.depth_maps(cl, frame.flush, "precompute", *frame.scene,
                            std::span<const LightView>(views).subspan(b0, count), RasterFilter{}, /*resolve=*/false,
                            &batch, &cull);
      for (int i = 0; i < count; ++i) records[b0 + i].first_texel = batch.first_texel(i);
      gpu::ensure_buffer(device, samples, count * sizeof(LamSampleView), "lam's batch of sample views");
      samples.upload(records.data() + b0, count * sizeof(LamSampleView));  // the rasterizer submitted
      cl.stage("precompute");
      for (int i = 0; i < count; ++i) {
        const LamSampleView& r = records[b0 + i];
        shader::LamInsertParams ip{};
        ip.keys = batch.keys() + r.first_texel * sizeof(uint64_t);
        ip.view = samples.address() + i * sizeof(LamSampleView);
        ip.layers = build.address();
        ip.counts = counts.address();
        ip.lists = lists.address();
        ip.list_counts = list_counts.address();
        ip.sample_counts = sample_counts_.address();
        ip.counters = counters_.address();
        ip.width = ref.width();
        ip.height = ref.height();
        ip.near = ref.near();
        ip.far = ref.far();
        ip.epsilon = map_.epsilon();
        ip.open_epsilon = map_.open_epsilon();
        ip.scene = frame.scene->address();
        ip.max_layers = K;
        ip.index = static_cast<uint32_t>(b0 + i);
        ip.list_capacity = slots;
        ip.slope = options_.slope ? 1u : 0u;
        ip.weighted = options_.slope && options_.weighted_splats ? 1u : 0u;
        ip.pixels = static_cast<uint32_t>(static_cast<uint64_t>(r.width) * r.height);
        cl.dispatch("lam_scatter", ip.pixels, ip);
        cl.dispatch("lam_insert", texels, ip);
      }
    }
    // The packed layers, sized from the counts: every layer ever created is kept.
    frame.flush();
    uint64_t layers = 0;
    for (const LamSampleCounts& c : sample_counts_.download_vector<LamSampleCounts>(n)) layers += c.layers;
    ranges_ = gpu::Buffer(device, texels * 2 * sizeof(uint32_t), "lam's texel ranges");
    layers_ = gpu::Buffer(device, std::max<uint64_t>(1, layers) * 2 * sizeof(float), "lam's layers");
    cl.stage("precompute");
    shader::LamFinalizeParams fp{};
    fp.build = build.address();
    fp.counts = counts.address();
    fp.ranges = ranges_.address();
    fp.layers = layers_.address();
    fp.counters = counters_.address();
    fp.texels = static_cast<uint32_t>(texels);
    fp.inv_samples = 1.0f / static_cast<float>(n);
    cl.dispatch("lam_finalize", texels, fp);
    // The build storage is freed on return: run what reads it first.
    frame.flush();
    peak_bytes_ = build.bytes() + counts.bytes() + lists.bytes() + list_counts.bytes() + batch.device_bytes() + rasterizer.scratch_device_bytes() +
                  samples.bytes() + ldi_bytes();
  }

  // What the finished LDI holds on the device.
  uint64_t ldi_bytes() const {
    return layers_.bytes() + ranges_.bytes() + view_.bytes() + outline_.bytes() + points_.bytes() + counters_.bytes() +
           sample_counts_.bytes();
  }

  lam::BuildOptions options_;
  bool bilinear_ = true;
  bool trace_unresolved_ = true;  // lam.cpp's `unresolved` and `trace_spread`
  float trace_spread_ = 0.005f;
  std::string suffix_;  // the light's suffix for the statistics (lam.cpp's)
  lam::AttenuationMap map_;  // the frame only (lam::attenuation_map_frame): the layers are on the device
  gpu::Buffer view_, outline_, points_, counters_, sample_counts_, ranges_, layers_;
  nlohmann::json extra_ = nlohmann::json::object();
  uint64_t peak_bytes_ = 0, sample_texels_ = 0;
  bool counting_ = false;
};

// One light's instance on the device: the build storage (max_layers slots a texel of a
// resolution^2 LDI, its counts), a batch of light-sample maps (sample views up to
// lam::sample_view_side_bound a side) with the rasterizer's scratch, and the packed LDI (at most
// every slot used) with its ranges; a few bytes per light sample.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  const int r = p.get_int("resolution");
  const uint64_t texels = ldi_texels(r), slots = texels * static_cast<uint64_t>(p.get_int("max_layers"));
  tally.add(slots * (sizeof(LamBuildLayer) + 2 * sizeof(float)) + texels * 4 * sizeof(uint32_t) +
                texels * list_slots(texels) * sizeof(LamSplatEntry) +
                sizeof(shader::LamMapView) + 16 * sizeof(Vec3f) + sizeof(LamCounters),
            "resolution");
  const int n = std::max(1, q.light_samples);
  const uint64_t per_view = sample_view_texels(r);
  const int batch = gpu::GpuBatchRasterizer::batch_size(q.triangles, per_view, false, n,
                                                        gpu::GpuBatchRasterizer::batch_budget());
  tally.add(gpu::GpuDepthMapBatch::bytes(batch * per_view, batch, false), "resolution");
  tally.add(gpu::GpuBatchRasterizer::scratch_bytes(q.triangles, batch, batch * per_view) + q.triangles * 4 +
                33 * sizeof(Vec3f),
            kTrianglesSetting);
  tally.add(static_cast<uint64_t>(n) * (sizeof(LamSampleCounts) + sizeof(LamSampleView) + sizeof(Vec3f)),
            kLightSamplesSetting);
  return tally.estimate();
}

}  // namespace

void lam::set_splat_list_capacity_for_testing(uint32_t slots) { g_list_slots_for_testing = slots; }

namespace {

const GpuMethodRegistration registration({"lam",
                                          [](const ParamSet& p) { return std::make_unique<LayeredAttenuationMapsGpu>(p); },
                                          memory});

}  // namespace
}  // namespace penumbra
