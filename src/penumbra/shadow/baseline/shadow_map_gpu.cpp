// `shadow-map` on the GPU: the CPU version's map from the light's centre (fitted on the device,
// rendered by the GPU rasterizer: shadow_map_common_gpu.h) and its lookups, the same function
// (shadow_map_shared.h shadow_map_visibility) in kernels/shadow_map_lookup.comp, one thread per
// view sample. Same parameters as shadow_map.cpp's table.
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/partitions/light_partitions_gpu.h"
#include "penumbra/shadow/shadow_map_common_gpu.h"

namespace penumbra {
namespace {

class ShadowMapGpu final : public GpuShadowMethod {
 public:
  explicit ShadowMapGpu(const ParamSet& p)
      : view_(shadow_map::view_params(p)), pcf_(p.get_int("pcf")), bilinear_(p.get_bool("bilinear")), bias_(shadow_map::bias_params(p)) {}

  void prepare(const ShadowContext& ctx, GpuFrame& frame) override {
    stats_.prepare_count++;
    map_.prepare(ctx, frame);
  }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    const bool has_map = map_.update(ctx, frame, view_, bias_, stats_);
    gpu::CommandList& cl = *frame.commands;
    cl.stage("lookup");
    shader::ShadowMapLookupParams p{};
    p.io = map_.lookup_inputs(cl, frame, out, has_map);
    p.light_center = light.center;
    p.pcf = pcf_;
    p.bilinear = bilinear_ ? 1u : 0u;
    p.light_n = light.frame.n;
    cl.dispatch("shadow_map_lookup", frame.slots, p);
  }

  // The texels read and the receivers outside the map, counted on the device.
  void collect_stats() override { map_.collect(stats_); }

 private:
  shadow_map::ViewParams view_;
  int pcf_;
  bool bilinear_;
  shadow_map::BiasParams bias_;
  shadow_map::GpuLightCentreMap map_;
};

// One light's instance on the device: the map, the rasterizer's scratch, a few bytes of fit and
// counters (shadow_map::GpuLightCentreMap::add_memory).
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  shadow_map::GpuLightCentreMap::add_memory(tally, p.get_int("resolution"), q);
  partitions::add_gpu_memory(tally, p, q);
  return tally.estimate();
}

const GpuMethodRegistration registration({"shadow-map", [](const ParamSet& p) {
                                            return partitions::wrap_gpu(std::make_unique<ShadowMapGpu>(p), p,
                                                                        p.get_int("resolution"));
                                          },
                                          memory});

}  // namespace
}  // namespace penumbra
