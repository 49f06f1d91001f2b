// `coherent-rt` on the GPU (agrawala2000 §5; docs/methods/coherent-rt.md, "On the GPU"): the
// CPU version's reference depth images built on the device (the GPU rasterizer's depth maps, then
// floors, walls, the shared min/max pyramid and the connectedness quadtree by the CPU's per-texel
// functions, reference_images_shared.h), and one thread per image tile shading its pixels in the
// CPU's Hilbert order with the CPU's SoftShad and depth-image tracer (soft_shad_shared.h,
// depth_image_trace_shared.h): the tile order semantics of the coherence prediction are the CPU's.
// Kernels and buffers: coherent_rt_kernels_shared.h.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>

#include "penumbra/core/error.h"
#include "penumbra/core/sampling.h"
#include "penumbra/gpu/gpu_light.h"
#include "penumbra/gpu/loop_limit.h"
#include "penumbra/gpu/minmax_pyramid_gpu.h"
#include "penumbra/gpu/raster/gpu_rasterizer.h"
#include "penumbra/shadow/coherent_rt/coherent_rt_kernels_shared.h"
#include "penumbra/shadow/coherent_rt/coherent_rt_settings.h"
#include "penumbra/shadow/gpu_method.h"

namespace penumbra {
namespace {

using namespace coherent_rt;

// A reference image on the device (ReferenceImage's planes, and its descriptor for the tiles).
struct GpuReferenceImage {
  LightView view;
  gpu::Buffer links, floors, connected, view_record;
  gpu::GpuMinMaxPyramid pyramid;
  uint64_t device_bytes() const {
    return links.bytes() + floors.bytes() + connected.bytes() + view_record.bytes() + pyramid.device_bytes();
  }
  // What an image of w x h texels holds: links and floors per texel, pyramid and connectedness
  // per node, its view.
  static uint64_t bytes(int w, int h) {
    const uint64_t texels = static_cast<uint64_t>(w) * static_cast<uint64_t>(h);
    return texels * 8 + MinMaxPyramid::bytes(w, h) + MinMaxPyramid::nodes(w, h) * 4 + sizeof(shader::RasterView);
  }
};

// Dispatches recorded between two looks at whether every tile is done (where the driver's loop
// limit splits the tiles' work).
constexpr uint64_t kDispatchBatch = 64;

// Spans per list per tile at first (they grow when a ray needs more); tests lower it.
constexpr int kFirstSpanCapacity = 32;
int first_span_capacity = kFirstSpanCapacity;

class CoherentRtGpu final : public GpuShadowMethod {
 public:
  explicit CoherentRtGpu(const ParamSet& p) : settings_(coherent_rt_settings(p)) {}

  bool computes_irradiance() const override { return true; }
  // tracer=geometry prepares nothing: it traces the geometry as the GPU holds it now.
  bool keeps_prepared_after_moving(std::span<const uint32_t>) override { return settings_.geometry; }

  void prepare(const ShadowContext& ctx, GpuFrame& frame) override {
    stats_.prepare_count++;
    coherent_rt::check_light(*ctx.light);
    gpu::Device& device = *frame.device;
    // A sphere light is sampled through its central disk (soft_shad.h sampled_light): the images
    // and the tiles see that disk, whose record the tiles read, and E is the sphere's closed form
    // times V (CrtTileBlock::sphere_emitter), as on the CPU.
    sampled_ = coherent_rt::sampled_light(*ctx.light);
    if (coherent_rt::sphere_emitter(*ctx.light))
      sampled_record_.emplace(device, sampled_);
    else
      sampled_record_.reset();
    images_.clear();
    extra_ = nlohmann::json::object();
    if (counters_buffer_.empty()) {
      counters_buffer_ = gpu::Buffer(device, sizeof(shader::CrtGpuCounters), "coherent-rt's counters");
      block_ = gpu::Buffer(device, sizeof(shader::CrtTileBlock), "coherent-rt's tiles");
    }
    light_field_ = 0;
    if (settings_.geometry) {
      descs_ = gpu::Buffer(device, 16, "coherent-rt's reference images");
      return;
    }
    gpu::CommandList& cl = *frame.commands;
    if (!rasterizer_) rasterizer_ = std::make_unique<gpu::GpuRasterizer>(device);
    std::vector<shader::CrtImageDesc> descs;
    nlohmann::json views = nlohmann::json::array();
    // No image where no caster can shadow a receiver (reference_view): nothing blocks a ray.
    const ShadowRegion region = fit_shadow_region(*ctx.scene, sampled_);
    light_field_ = settings_.light_field ? region.light_field : 0.0f;  // coherent_rt.cpp
    const std::vector<Vec3f> eyes = region.empty ? std::vector<Vec3f>{} : view_points(sampled_, settings_.views);
    for (Vec3f eye : eyes) {
      GpuReferenceImage img;
      img.view = reference_view(region, sampled_, eye, settings_.images.resolution);
      const int w = img.view.width(), h = img.view.height();
      const uint64_t texels = static_cast<uint64_t>(w) * static_cast<uint64_t>(h);
      // The depth map (one, reused for every view: each image is built before the next map).
      rasterizer_->depth_map(cl, frame.flush, "precompute", *frame.scene, img.view, RasterFilter{}, &map_);
      img.links = gpu::Buffer(device, texels * 4, "a reference image's walls");
      img.floors = gpu::Buffer(device, texels * 4, "a reference image's floors");
      img.connected = gpu::Buffer(device, MinMaxPyramid::nodes(w, h) * 4, "a reference image's connectedness");
      img.pyramid.resize(device, w, h, "a reference image's pyramid");
      const shader::RasterView record = img.view.shared();
      img.view_record = gpu::Buffer(device, sizeof(record), "a reference image's view");
      img.view_record.upload(&record, sizeof(record));
      shader::CrtBuildParams bp{};
      bp.z = map_.z();
      bp.triangle = map_.triangle();
      bp.links = img.links.address();
      bp.floors = img.floors.address();
      bp.nodes = img.pyramid.address();
      bp.connected = img.connected.address();
      bp.view = img.view_record.address();
      bp.levels = img.pyramid.levels_address();
      bp.level_count = img.pyramid.levels();
      bp.options = {settings_.images.gap_bias, settings_.images.shadow_bias, settings_.images.slope_bias,
                    settings_.images.open_shadow_bias};
      bp.scene = frame.scene->address();
      bp.width = w;
      bp.height = h;
      cl.stage("precompute");
      cl.dispatch("crt_links", texels, bp);
      cl.dispatch("crt_floors", texels, bp);
      cl.dispatch("crt_ranges", texels, bp);
      img.pyramid.build(cl);
      // The connectedness quadtree, level by level above the texels.
      int lw = w, lh = h;
      for (int level = 1; level < img.pyramid.levels(); ++level) {
        lw = (lw + 1) / 2;
        lh = (lh + 1) / 2;
        bp.level = level;
        cl.dispatch("crt_connected", static_cast<uint64_t>(lw) * static_cast<uint64_t>(lh), bp);
      }
      shader::CrtImageDesc d{};
      d.floors = img.floors.address();
      d.links = img.links.address();
      d.connected = img.connected.address();
      d.nodes = img.pyramid.address();
      d.levels = img.pyramid.levels_address();
      d.width = w;
      d.height = h;
      d.level_count = img.pyramid.levels();
      d.view = record;
      descs.push_back(d);
      views.push_back({{"width", w}, {"height", h}, {"near", img.view.near()}, {"far", img.view.far()}});
      images_.push_back(std::move(img));
    }
    // The maps are built when the frame runs; the next depth map waits for nothing (each
    // depth_map call submits what was recorded first).
    descs_ = descs.empty() ? gpu::Buffer(device, 16, "coherent-rt's reference images")
                           : gpu::make_buffer<shader::CrtImageDesc>(device, descs, "coherent-rt's reference images");
    uint64_t bytes = map_.device_bytes();
    for (const GpuReferenceImage& img : images_) bytes += img.device_bytes();
    memory_bytes_ = bytes;
    extra_["views"] = std::move(views);
  }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    gpu::Device& device = *frame.device;
    gpu::CommandList& cl = *frame.commands;
    const int n = std::max(1, ctx.light_samples);
    int cols = 1, rows = 1;
    stratification_grid(n, &cols, &rows);
    const StratifiedGrid grid(n);
    const int tile = settings_.tile;
    // The tiles are the whole image's (tile-aligned from its top left corner), clipped to the
    // window (coherent_rt.cpp: a crop on tile boundaries shades its pixels as the whole frame).
    const PixelWindow& window = frame.window;
    shader::CrtTileBlock b{};
    b.trace = settings_.trace.shared();
    b.cols = cols;
    b.rows = rows;
    b.sub_grid = settings_.sampling.sub_grid;
    b.coherence = settings_.sampling.coherence ? 1u : 0u;
    b.shortcut = settings_.sampling.shortcut ? 1u : 0u;
    b.reset_distance = settings_.sampling.reset_distance;
    b.window_x0 = window.x0;
    b.window_y0 = window.y0;
    b.window_x1 = window.x1;
    b.window_y1 = window.y1;
    b.spp = frame.samples_per_pixel;
    b.tile = tile;
    b.tile_x0 = window.x0 / tile;
    b.tile_y0 = window.y0 / tile;
    b.tiles_x = (window.x1 - 1) / tile + 1 - b.tile_x0;
    b.tiles_y = (window.y1 - 1) / tile + 1 - b.tile_y0;
    b.n = n;
    b.grid_cols = grid.cols();
    b.inv_cols = grid.inv_cols();
    b.inv_rows = grid.inv_rows();
    b.images = static_cast<int>(images_.size());
    b.own_plane = settings_.own_plane ? 1u : 0u;
    b.geometry = settings_.geometry ? 1u : 0u;
    b.sphere_emitter = sampled_record_ ? frame.light : 0;
    // The near field (coherent_rt.cpp): the part of each ray near enough its point for an occluder's
    // penumbra to be narrower than near_field texels, through the BVH.
    std::vector<LightView> views;
    for (const GpuReferenceImage& img : images_) views.push_back(img.view);
    if (!settings_.geometry) {
      const NearFieldFrame near = near_field_frame(settings_.near_field, sampled_, views);
      b.near_scale = near.scale;
      b.near_light_width = near.light_width;
      b.near_eye = near.eye;
      b.near_forward = near.forward;
      b.light_field = light_field_;  // the light field (coherent_rt.cpp): its part of each ray through the BVH
    }
    const uint64_t tiles = static_cast<uint64_t>(b.tiles_x) * static_cast<uint64_t>(b.tiles_y);
    const uint64_t scratch = tiles * shader::crt_tile_scratch_words(n, b.sub_grid) * 4;
    gpu::ensure_buffer(device, scratch_, scratch, "coherent-rt's tile samplers");
    cl.stage("trace");
    // A tile's work: per step (Hilbert step x view sample) one unit (passed over, or its point
    // started) and at most n cells.
    const uint64_t work = static_cast<uint64_t>(tile) * tile * frame.samples_per_pixel * (static_cast<uint64_t>(n) + 1);

    // A ray whose occlusion spans outgrow their lists ends its tile early: the tiles are traced
    // again with longer lists (every tile anew: the same points, the same answers). A dispatch
    // that ran into the driver's loop limit (lavapipe) is traced again in shorter dispatches.
    for (;;) {
      b.span_capacity = span_capacity_;
      const uint64_t spans = tiles * 3 * static_cast<uint64_t>(span_capacity_) * 8;
      gpu::ensure_buffer(device, spans_, spans, "coherent-rt's occlusion spans");
      frame.flush();  // nothing recorded may still read the block
      block_.upload(&b, sizeof(b));
      cl.stage("trace");
      cl.fill(counters_buffer_, 0);
      cl.fill(counters_buffer_, 0xffffffffu, offsetof(shader::CrtGpuCounters, limited_after), 4);
      shader::CrtTilesParams tp{};
      tp.scene = frame.scene->address();
      tp.samples = frame.view_samples;
      tp.light = sampled_record_ ? sampled_record_->address() : frame.light;
      tp.visibility = out.visibility;
      tp.irradiance = out.irradiance;
      tp.block = block_.address();
      tp.descs = descs_.address();
      tp.scratch = scratch_.address();
      tp.spans = spans_.address();
      tp.counters = counters_buffer_.address();
      tp.seed = ctx.seed;
      tp.light_index = ctx.light_index;
      tp.frame = ctx.frame;
      tp.cell_budget = cells_per_dispatch_;
      tp.canary = gpu::kLoopLimitCanary;
      // agrawala2000 §5.2's order is sequential within a tile: the dispatches of one tile's work
      // run one after the other (the list's barriers), each tile's place and sampler kept in its
      // scratch, in batches until no tile has work left (at most `work` cells a tile).
      shader::CrtGpuCounters c{};
      uint64_t recorded = 0;
      for (;;) {
        const uint64_t batch = cells_per_dispatch_ <= 0 ? 1 : kDispatchBatch;
        cl.fill(counters_buffer_, 0, offsetof(shader::CrtGpuCounters, unfinished), 4);
        for (uint64_t d = 0; d < batch; ++d, ++recorded) {
          tp.resume = recorded == 0 ? 0 : 1;
          cl.dispatch("coherent_rt_tiles", tiles, tp);
        }
        frame.flush();
        counters_buffer_.download(&c, sizeof(c));
        if (c.limited != 0 || c.unfinished == 0 || cells_per_dispatch_ <= 0 ||
            recorded * static_cast<uint64_t>(cells_per_dispatch_) >= work)
          break;
        cl.stage("trace");
      }
      if (c.limited != 0) {
        if (cells_per_dispatch_ == 1)
          throw Error("coherent-rt on {}: one light cell's ray exceeds the driver's loop limit", device.info().name);
        // The fewest cells a limited tile evaluated (its last one perhaps cut short), halved.
        const int fewest = static_cast<int>(std::min<uint32_t>(c.limited_after, 1u << 30));
        cells_per_dispatch_ = std::max(1, cells_per_dispatch_ > 0 ? std::min(fewest, cells_per_dispatch_) / 2 : fewest / 2);
        ++limit_retries_;
        continue;
      }
      if (c.overflow == 0) {
        add(c);
        break;
      }
      ++span_retries_;
      span_capacity_ *= 4;
    }
    light_suffix_ = ctx.light_index == 0 ? "" : "_light" + std::to_string(ctx.light_index);
    light_samples_ = n;
    counted_ = true;
  }

  void collect_stats() override {
    if (!counted_) return;
    counted_ = false;
    const shader::CrtGpuCounters& t = totals_;
    const uint64_t traced = settings_.geometry ? t.geometry_rays : t.traced;
    stats_.rays_traced += traced;
    stats_.texels_visited += t.nodes;
    stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, memory_bytes_);
    const double points = std::max<double>(1, static_cast<double>(t.points));
    const double rays = std::max<double>(1, static_cast<double>(t.traced));
    nlohmann::json extra = extra_;
    extra["tracer"] = settings_.geometry ? "geometry" : "depth-images";
    extra["light_samples"] = light_samples_;
    extra["points"] = t.points;
    extra["rays_per_point"] = traced / points;
    extra["ray_fraction"] = traced / (points * light_samples_);
    extra["cells_evaluated_per_point"] = t.rays / points;
    extra["own_plane_cells_per_point"] = t.own_plane_cells / points;
    if (!settings_.geometry) {
      extra["near_field_rays_per_point"] = t.near_rays / points;
      extra["light_field"] = light_field_;
      extra["light_field_rays_per_point"] = t.light_rays / points;
    }
    extra["span_capacity"] = span_capacity_;
    extra["span_retries"] = span_retries_;
    extra["cells_per_dispatch"] = cells_per_dispatch_;
    extra["loop_limit_retries"] = limit_retries_;
    if (settings_.sampling.coherence)
      extra["coherence"] = {{"resets", t.resets},
                            {"predicted_wrong_per_point", t.predicted_wrong / points},
                            {"shortcut_cells_per_point", t.shortcut_cells / points},
                            {"blocker_points_per_point", t.blocker_points / points}};
    if (!settings_.geometry)
      extra["depth_images"] = {{"maps_per_ray", t.maps_walked / rays},
                               {"blocked_fraction", t.blocked / rays},
                               {"clear_miss_fraction", t.clear_misses / rays},
                               {"intervals_exhausted_fraction", t.intervals_exhausted / rays},
                               {"connected_hit_fraction", t.connected_hits / rays},
                               {"hidden_everywhere_fraction", t.hidden_everywhere / rays},
                               {"nodes_per_ray", t.nodes / rays},
                               {"texels_per_ray", t.texels / rays}};
    for (auto it = extra.begin(); it != extra.end(); ++it) stats_.extra[it.key() + light_suffix_] = it.value();
    totals_ = {};
  }

 private:
  void add(const shader::CrtGpuCounters& c) {
    uint64_t* dst = &totals_.points;
    const uint64_t* src = &c.points;
    // The 64-bit counters, points .. light_rays, in order.
    constexpr int kCounters = (offsetof(shader::CrtGpuCounters, light_rays) - offsetof(shader::CrtGpuCounters, points)) /
                                  sizeof(uint64_t) + 1;
    static_assert(kCounters == 19);
    for (int k = 0; k < kCounters; ++k) dst[k] += src[k];
  }

  CoherentRtSettings settings_;
  std::unique_ptr<gpu::GpuRasterizer> rasterizer_;
  gpu::GpuDepthMap map_;
  std::vector<GpuReferenceImage> images_;
  gpu::Buffer descs_, block_, counters_buffer_, scratch_, spans_;
  AreaLight sampled_;  // the light the passes sample (soft_shad.h sampled_light)
  // Its record, where it is not the scene's light (a sphere's disk).
  std::optional<gpu::GpuLightBuffer> sampled_record_;
  int span_capacity_ = first_span_capacity;
  uint64_t span_retries_ = 0;
  float light_field_ = 0;  // ShadowRegion::light_field of the prepared light (0: none)
  // Light cells (and point starts) of every tile per dispatch: 0 for all of them, unless the
  // driver limits the loops of one invocation (lavapipe), then as many as fit, learned by retrying.
  int cells_per_dispatch_ = 0;
  uint64_t limit_retries_ = 0;
  shader::CrtGpuCounters totals_{};
  bool counted_ = false;
  int light_samples_ = 1;
  uint64_t memory_bytes_ = 0;
  std::string light_suffix_;
  nlohmann::json extra_ = nlohmann::json::object();
};

// One light's device memory: the reference images (floors, walls, pyramid and connectedness of
// resolution^2 texels each) and one depth map while they are built, the rasterizer's scratch, and
// per tile its sampler and span lists. The tiles are bounded for a square window of the view
// samples' pixels.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  const CoherentRtSettings s = coherent_rt_settings(p);
  if (!s.geometry) {
    const int r = s.images.resolution;
    const uint64_t views = static_cast<uint64_t>(view_point_count(s.views));
    tally.add(views * GpuReferenceImage::bytes(r, r) + gpu::GpuDepthMap::bytes(r, r), "resolution");
    tally.add(gpu::GpuRasterizer::scratch_bytes(q.triangles, r, r), kTrianglesSetting);
  }
  const uint64_t side = static_cast<uint64_t>(std::ceil(std::sqrt(static_cast<double>(std::max<uint64_t>(1, q.view_samples)))));
  const uint64_t per_side = (side + static_cast<uint64_t>(s.tile) - 1) / static_cast<uint64_t>(s.tile) + 1;
  const uint64_t tiles = per_side * per_side;
  tally.add(tiles * 3 * kFirstSpanCapacity * 8, kViewSamplesSetting);
  const int n = std::max(1, q.light_samples);
  tally.add(tiles * shader::crt_tile_scratch_words(n, s.sampling.sub_grid) * 4, kLightSamplesSetting);
  return tally.estimate();
}

const GpuMethodRegistration registration({"coherent-rt", [](const ParamSet& p) { return std::make_unique<CoherentRtGpu>(p); },
                                          memory});

}  // namespace

namespace coherent_rt {
void set_first_gpu_span_capacity_for_testing(int spans) { first_span_capacity = spans > 0 ? spans : kFirstSpanCapacity; }
}  // namespace coherent_rt

}  // namespace penumbra
