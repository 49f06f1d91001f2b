// `multi-view-sm` on the GPU (issue 30): the CPU version's light points (the same LightSampleSet
// and sample_area), each point's view fitted to the receivers on the device (every view in one
// pass over the view samples, kernels/multi_view_fit.comp; the host builds the views with the
// CPU's code), the maps rendered many at once by the GPU rasterizer's batch mode
// (gpu/raster/gpu_batch_rasterizer.h), and each view sample looked up in every map of a batch
// (kernels/multi_view_lookup.comp, shadow_map_shared.h sm_lookup: the CPU's lookup and biases),
// V summed in the CPU's order; the near field of each shadow ray (multi_view_shared.h) traced
// through the device's BVH where the CPU traces it through Embree. The CPU renders one map at a
// time; the GPU holds a batch of maps (GpuBatchRasterizer::batch_budget) so each pass fills the
// device. Same parameters as multi_view_shadow_map.cpp's table.
#include <algorithm>

#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"
#include "penumbra/gpu/raster/gpu_batch_rasterizer.h"
#include "penumbra/gpu/raster/object_culling.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadow/baseline/multi_view_shared.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/partitions/light_partitions_gpu.h"
#include "penumbra/shadow/shadow_map_common_gpu.h"

namespace penumbra {
namespace {

using shader::GpuReceiverRange;
using shader::MultiViewMap;

// The maps of one batch at most this many texels each: a fitted view at `resolution`.
uint64_t map_texels(int resolution) {
  const ViewSize v = fitted_view_bound(resolution);
  return static_cast<uint64_t>(v.width) * static_cast<uint64_t>(v.height);
}

class MultiViewShadowMapGpu final : public GpuShadowMethod {
 public:
  explicit MultiViewShadowMapGpu(const ParamSet& p)
      : view_(shadow_map::view_params(p)), bias_(shadow_map::bias_params(p)), near_field_(p.get_float("near_field")) {}

  void prepare(const ShadowContext& ctx, GpuFrame& frame) override {
    stats_.prepare_count++;
    casters_ = ctx.scene->bounds();
    culling_.prepare(*frame.device, *ctx.scene);
    if (!rasterizer_) {
      rasterizer_ = std::make_unique<gpu::GpuBatchRasterizer>(*frame.device);
      counters_ = gpu::Buffer(*frame.device, 2 * sizeof(uint64_t), "multi-view-sm's counters");
    }
  }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    gpu::CommandList& cl = *frame.commands;
    const int maps = std::max(1, ctx.light_samples);
    // The CPU's light points (multi_view_shadow_map.cpp): one fixed set per light and frame.
    const LightSampleSet set(maps, hash_combine(hash_combine(ctx.seed, 0x4d5653u /* "MVS" */ + ctx.light_index), ctx.frame),
                             /*per_pixel=*/false);
    ShadowViewFit fit;
    fit.resolution = view_.resolution;
    fit.max_fov = view_.max_fov;
    std::vector<ShadowViewFrame> frames;
    std::vector<Vec3f> eyes;
    for (int i = 0; i < maps; ++i) {
      eyes.push_back(light.sample_area(set.sample(i, 0)));
      frames.push_back(shadow_view_frame(eyes.back(), light.frame.n, light.frame.t, casters_, {}, fit));
    }

    // The fit: every view's receiver range in one pass, read back (32 bytes a view).
    cl.stage("fit");
    gpu::ensure_buffer(*frame.device, ranges_, maps * sizeof(GpuReceiverRange), "multi-view-sm's receiver ranges");
    gpu::ensure_buffer(*frame.device, eyes_, maps * sizeof(Vec3f), "multi-view-sm's light points");
    const std::vector<GpuReceiverRange> empty(maps, shadow_map::empty_receiver_range());
    ranges_.upload(empty.data(), maps * sizeof(GpuReceiverRange));
    eyes_.upload(eyes.data(), maps * sizeof(Vec3f));
    shader::MultiViewFitParams fp{};
    fp.axes = frames[0].axes;  // the eyes differ; min_near and the axes are every view's
    fp.samples = frame.view_samples;
    fp.ranges = ranges_.address();
    fp.eyes = eyes_.address();
    fp.light_center = light.center;
    fp.slots = frame.slots;
    fp.light_n = light.frame.n;
    fp.views = static_cast<uint32_t>(maps);
    cl.dispatch("multi_view_fit", frame.slots, fp);
    frame.flush();
    const std::vector<GpuReceiverRange> ranges = ranges_.download_vector<GpuReceiverRange>(maps);

    shader::MultiViewLookupParams lp{};
    lp.scene = frame.scene->address();
    lp.samples = frame.view_samples;
    lp.visibility = out.visibility;
    lp.counters = counters_.address();
    lp.bias = bias_.shared();
    lp.light_center = light.center;
    lp.slots = frame.slots;
    lp.light_n = light.frame.n;
    lp.near_field = near_field_;
    lp.light_width = shader::near_field_light_width(light.area());
    if (!counting_) cl.fill(counters_, 0);
    counting_ = true;
    if (ranges[0].receivers == 0) {
      // No receiver in front of the light: V = 0 everywhere, no map.
      cl.stage("lookup");
      lp.first = 1;
      lp.scale = 1.0f;
      cl.dispatch("multi_view_lookup", frame.slots, lp);
      return;
    }
    std::vector<LightView> views;
    for (int i = 0; i < maps; ++i) views.push_back(shadow_map::view_from_range(frames[i], ranges[i], casters_, fit));

    // The maps in batches, each looked up by every view sample before the next is rendered.
    const int batch = gpu::GpuBatchRasterizer::batch_size(frame.scene->triangle_count(), map_texels(view_.resolution),
                                                          /*resolve=*/true, maps, gpu::GpuBatchRasterizer::batch_budget());
    uint64_t culled = 0;
    for (int b0 = 0; b0 < maps; b0 += batch) {
      const int n = std::min(batch, maps - b0);
      const std::span<const LightView> batch_views = std::span<const LightView>(views).subspan(b0, n);
      // The objects wholly outside a map's fitted view are not set up for it (issue 34 part 3;
      // the CPU culls runs of triangles alike): the maps are the same, the cost follows the view.
      uint64_t batch_culled = 0;
      const bool cull = culling_.flags_for_views(batch_views, &view_culling_, &batch_culled);
      culled += batch_culled;
      rasterizer_->depth_maps(cl, frame.flush, "raster", *frame.scene, batch_views, RasterFilter{}, /*resolve=*/true,
                              &batch_, nullptr, cull ? &view_culling_ : nullptr);
      std::vector<MultiViewMap> records(n);
      for (int i = 0; i < n; ++i) {
        records[i].map = shadow_map::shadow_map_view(views[b0 + i], kInfinity);  // z_min: unused by sm_lookup
        records[i].first_texel = batch_.first_texel(i);
      }
      gpu::ensure_buffer(*frame.device, maps_, n * sizeof(MultiViewMap), "multi-view-sm's batch of views");
      maps_.upload(records.data(), n * sizeof(MultiViewMap));  // the rasterizer submitted the last lookups
      cl.stage("lookup");
      lp.maps = maps_.address();
      lp.z = batch_.z();
      lp.opacity = batch_.opacity();
      lp.map_count = static_cast<uint32_t>(n);
      lp.first = b0 == 0 ? 1u : 0u;
      lp.scale = b0 + n == maps ? 1.0f / static_cast<float>(maps) : 1.0f;
      cl.dispatch("multi_view_lookup", frame.slots, lp);
    }
    stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, batch_.device_bytes() + rasterizer_->scratch_device_bytes() +
                                                                     ranges_.bytes() + eyes_.bytes() + maps_.bytes());
    stats_.extra["maps"] = maps;
    stats_.extra["culled_triangles"] = culled;
    stats_.extra["maps_per_batch"] = batch;
    stats_.extra["map_width"] = views.back().width();
    stats_.extra["map_height"] = views.back().height();
  }

  // The texels read and the near fields traced, counted on the device.
  void collect_stats() override {
    if (!counting_) return;
    uint64_t counts[2] = {0, 0};
    counters_.download(counts, sizeof(counts));
    stats_.texels_visited += counts[0];
    stats_.extra["near_field_rays"] = counts[1];
    counting_ = false;
  }

 private:
  shadow_map::ViewParams view_;
  shadow_map::BiasParams bias_;
  float near_field_;  // sm_near_field_length's texels (0: the maps alone)
  Bounds3f casters_;
  std::unique_ptr<gpu::GpuBatchRasterizer> rasterizer_;
  gpu::ObjectCulling culling_;
  gpu::RasterViewCulling view_culling_;
  gpu::GpuDepthMapBatch batch_;
  gpu::Buffer ranges_, eyes_, maps_, counters_;
  bool counting_ = false;
};

// One light's instance on the device: a batch of maps (resolution^2 texels each, their keys and
// planes) and the rasterizer's scratch for it, the fit's ranges and light points, the batch's
// view records.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  const int maps = std::max(1, q.light_samples);
  const uint64_t texels = map_texels(p.get_int("resolution"));
  const int batch = gpu::GpuBatchRasterizer::batch_size(q.triangles, texels, /*resolve=*/true, maps,
                                                        gpu::GpuBatchRasterizer::batch_budget());
  tally.add(gpu::GpuDepthMapBatch::bytes(batch * texels, batch, /*resolve=*/true), "resolution");
  tally.add(gpu::GpuBatchRasterizer::scratch_bytes(q.triangles, batch, batch * texels), kTrianglesSetting);
  tally.add(static_cast<uint64_t>(maps) * (sizeof(GpuReceiverRange) + sizeof(Vec3f)) + batch * sizeof(MultiViewMap) +
                2 * sizeof(uint64_t),
            kLightSamplesSetting);
  partitions::add_gpu_memory(tally, p, q);
  return tally.estimate();
}

const GpuMethodRegistration registration({"multi-view-sm",
                                          [](const ParamSet& p) {
                                            return partitions::wrap_gpu(std::make_unique<MultiViewShadowMapGpu>(p), p,
                                                                        p.get_int("resolution"));
                                          },
                                          memory});

}  // namespace
}  // namespace penumbra
