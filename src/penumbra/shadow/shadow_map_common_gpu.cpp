#include "penumbra/shadow/shadow_map_common_gpu.h"

#include "penumbra/core/error.h"
#include "penumbra/scene/scene.h"

namespace penumbra::shadow_map {
namespace {

using shader::GpuReceiverRange;

constexpr uint32_t kSmallest = 0xffffffffu;  // a range's minimum before any receiver

// A float reduced as raster_order_bits back into the float.
float range_float(uint32_t bits) { return shader::raster_order_float(bits); }

}  // namespace

ShadowViewRange range_floats(const GpuReceiverRange& r) {
  ShadowViewRange range;
  if (r.fitted > 0) {
    range.x0 = range_float(r.x0);
    range.x1 = range_float(r.x1);
    range.y0 = range_float(r.y0);
    range.y1 = range_float(r.y1);
    range.z0 = range_float(r.z0);
    range.z1 = range_float(r.z1);
  }
  return range;
}

LightView view_from_range(const ShadowViewFrame& frame, const GpuReceiverRange& r, const Bounds3f& casters,
                          const ShadowViewFit& fit) {
  return build_shadow_view(frame, range_floats(r), casters, fit);
}

GpuReceiverRange empty_receiver_range() {
  GpuReceiverRange r{};
  r.x0 = r.y0 = r.z0 = kSmallest;
  return r;
}

GpuReceiverRange reduce_receivers(const AreaLight& light, GpuFrame& frame, const ShadowViewFrame& frame_axes,
                                  gpu::Buffer& range_buffer) {
  gpu::CommandList& cl = *frame.commands;
  cl.fill(range_buffer, 0);
  for (uint64_t offset : {offsetof(GpuReceiverRange, x0), offsetof(GpuReceiverRange, y0), offsetof(GpuReceiverRange, z0)})
    cl.fill(range_buffer, kSmallest, offset, 4);
  shader::FitReceiversParams fp{};
  fp.samples = frame.view_samples;
  fp.range = range_buffer.address();
  fp.axes = frame_axes.axes;
  fp.light_center = light.center;
  fp.slots = frame.slots;
  fp.light_n = light.frame.n;
  cl.dispatch("shadow_fit_receivers", frame.slots, fp);
  frame.flush();
  GpuReceiverRange r{};
  range_buffer.download(&r, sizeof(r));
  return r;
}

std::optional<LightView> fit_light_centre_view(const ShadowContext& ctx, GpuFrame& frame, const ViewParams& params,
                                               const Bounds3f& casters, const ShadowRegion& reach,
                                               gpu::Buffer& range_buffer) {
  const AreaLight& light = *ctx.light;
  // The fit: the receivers reduced on the device, 32 bytes read back, the view built here by
  // the CPU's code (light_view_from's frame: from the light's centre along its normal).
  ShadowViewFit fit;
  fit.resolution = params.resolution;
  fit.max_fov = params.max_fov;
  set_reach(fit, reach);
  const ShadowViewFrame frame_axes = shadow_view_frame(light.center, light.frame.n, light.frame.t, casters, {}, fit);
  frame.commands->stage("fit");
  const GpuReceiverRange r = reduce_receivers(light, frame, frame_axes, range_buffer);
  if (r.receivers == 0) return std::nullopt;
  return view_from_range(frame_axes, r, casters, fit);
}

void GpuLightCentreMap::prepare(const ShadowContext& ctx, GpuFrame& frame, bool hold_reach) {
  casters_ = ctx.scene->bounds();
  reach_ = hold_reach ? shadow_reach(*ctx.scene, *ctx.light) : ShadowRegion{};
  culling_.prepare(*frame.device, *ctx.scene);
  valid_ = false;
  if (!rasterizer_) {
    rasterizer_ = std::make_unique<gpu::GpuRasterizer>(*frame.device);
    range_ = gpu::Buffer(*frame.device, sizeof(GpuReceiverRange), "the shadow map's receiver range");
    block_ = gpu::Buffer(*frame.device, sizeof(shader::ShadowMapBlock), "the shadow map's view");
    counters_ = gpu::Buffer(*frame.device, sizeof(shader::GpuShadowMapCounters), "the shadow map's counters");
  }
}

bool GpuLightCentreMap::update(const ShadowContext& ctx, GpuFrame& frame, const ViewParams& params,
                               const BiasParams& bias, MethodStats& stats) {
  gpu::CommandList& cl = *frame.commands;
  const std::optional<LightView> fitted = fit_light_centre_view(ctx, frame, params, casters_, reach_, range_);
  if (!fitted) return false;
  const LightView& view = *fitted;
  // Rendered again only when the fitted view changed (LightCentreMap::update's rule).
  if (!(valid_ && same_fitted_view(map_.view(), view))) {
    // The objects wholly outside the view are left out (after the fit's flush: no recorded
    // kernel still reads the flags).
    uint64_t culled = 0;
    const uint64_t flags = culling_.flags_for(view, &culled);
    rasterizer_->depth_map(cl, frame.flush, "raster", *frame.scene, view, RasterFilter{}, &map_, flags);
    stats.add_count("culled_triangles", culled);
    shader::ShadowMapBlock block{};
    block.map = shadow_map_view(view, map_.z_min());
    block.bias = bias.shared();
    block_.upload(&block, sizeof(block));
    valid_ = true;
    ++renders_;
  }
  stats.memory_bytes = std::max<uint64_t>(stats.memory_bytes, map_.device_bytes());
  stats.extra["map_width"] = map_.width();
  stats.extra["map_height"] = map_.height();
  return true;
}

shader::ShadowMapInputs GpuLightCentreMap::lookup_inputs(gpu::CommandList& commands, const GpuFrame& frame,
                                                          const GpuShadowOutput& out, bool has_map) {
  if (!counting_) commands.fill(counters_, 0);
  counting_ = true;
  shader::ShadowMapInputs in{};
  in.scene = frame.scene->address();
  in.samples = frame.view_samples;
  in.visibility = out.visibility;
  if (has_map) {
    in.z = map_.z();
    in.opacity = map_.opacity();
  }
  in.block = block_.address();
  in.counters = counters_.address();
  in.slots = frame.slots;
  in.has_map = has_map ? 1u : 0u;
  return in;
}

shader::GpuShadowMapCounters GpuLightCentreMap::collect(MethodStats& stats) {
  shader::GpuShadowMapCounters c{};
  if (!counting_) return c;
  counters_.download(&c, sizeof(c));
  counting_ = false;
  stats.texels_visited += c.texels;
  stats.extra["receivers_outside_map"] = c.outside;
  return c;
}

void GpuLightCentreMap::add_memory(MemoryTally& tally, int resolution, const MemoryQuery& q) {
  const ViewSize v = fitted_view_bound(resolution);
  tally.add(gpu::GpuDepthMap::bytes(v.width, v.height), "resolution");
  tally.add(gpu::GpuRasterizer::scratch_bytes(q.triangles, v.width, v.height), kTrianglesSetting);
  tally.add(sizeof(GpuReceiverRange) + sizeof(shader::ShadowMapBlock) + sizeof(shader::GpuShadowMapCounters),
            "resolution");
}

}  // namespace penumbra::shadow_map
