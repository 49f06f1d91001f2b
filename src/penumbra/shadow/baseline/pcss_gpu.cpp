// `pcss` on the GPU (both variants): the CPU version's map from the light's centre (fitted on the
// device, rendered by the GPU rasterizer: shadow_map_common_gpu.h) and its filter, the same
// function (shadow_map_shared.h pcss_visibility) in kernels/pcss_filter.comp, one thread per view
// sample, with the CPU's kernels (uploaded) and per-pixel shifts (pcss_common.h). Same
// parameters as pcss.cpp's table.
#include "penumbra/shadow/baseline/pcss_common.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/partitions/light_partitions_gpu.h"
#include "penumbra/shadow/shadow_map_common_gpu.h"

namespace penumbra {
namespace {

class PcssGpu final : public GpuShadowMethod {
 public:
  explicit PcssGpu(const ParamSet& p) : s_(p) {}

  void prepare(const ShadowContext& ctx, GpuFrame& frame) override {
    stats_.prepare_count++;
    map_.prepare(ctx, frame);
  }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    const bool has_map = map_.update(ctx, frame, s_.view, s_.bias, stats_);
    // The kernels of this light and frame (the CPU's points), uploaded when the key changes.
    const uint64_t key = pcss::kernel_key(ctx);
    if (blocker_.empty() || key != key_) {
      const pcss::Kernels k = pcss::kernels(s_, key);
      blocker_ = gpu::make_buffer<Vec2f>(*frame.device, k.blocker, "pcss's blocker-search kernel");
      pcf_ = gpu::make_buffer<Vec2f>(*frame.device, k.pcf, "pcss's filter kernel");
      key_ = key;
    }
    gpu::CommandList& cl = *frame.commands;
    cl.stage("filter");
    shader::PcssFilterParams p{};
    p.io = map_.lookup_inputs(cl, frame, out, has_map);
    p.light = frame.light;
    p.blocker_base = blocker_.address();
    p.pcf_base = pcf_.address();
    p.key = key;
    p.blocker_samples = s_.blocker_samples;
    p.pcf_samples = s_.pcf_samples;
    p.xie2007 = s_.xie2007 ? 1u : 0u;
    p.jitter = s_.jitter ? 1u : 0u;
    p.extent_radius = ctx.light->extent_radius();
    cl.dispatch("pcss_filter", frame.slots, p);
    ran_ = true;
  }

  // The texels read, the receivers outside the map, the samples without blockers and z_min.
  void collect_stats() override {
    if (!ran_) return;
    const shader::GpuShadowMapCounters c = map_.collect(stats_);
    stats_.extra["z_min"] = map_.map().z_min();
    if (!s_.xie2007) stats_.extra["samples_without_blockers"] = c.no_blocker;
    ran_ = false;
  }

 private:
  pcss::Settings s_;
  shadow_map::GpuLightCentreMap map_;
  gpu::Buffer blocker_, pcf_;
  uint64_t key_ = 0;
  bool ran_ = false;
};

// One light's instance on the device: the map, the rasterizer's scratch, the fit's and the
// counters' bytes (shadow_map::GpuLightCentreMap::add_memory), and the two kernels.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  shadow_map::GpuLightCentreMap::add_memory(tally, p.get_int("resolution"), q);
  tally.add(static_cast<uint64_t>(p.get_int("blocker_samples") + p.get_int("pcf_samples")) * sizeof(Vec2f),
            "pcf_samples");
  partitions::add_gpu_memory(tally, p, q);
  return tally.estimate();
}

const GpuMethodRegistration registration({"pcss", [](const ParamSet& p) {
                                            return partitions::wrap_gpu(std::make_unique<PcssGpu>(p), p,
                                                                        p.get_int("resolution"));
                                          },
                                          memory});

}  // namespace
}  // namespace penumbra
