// `reference` on the GPU: the CPU version's estimators and light samples (reference.cpp), one
// thread per view sample tracing its n shadow rays through the GPU's BVH
// (kernels/reference_fans.comp). At one seed and spp it traces the CPU's rays up to float
// rounding (gpu_reference_test.cpp). Where the driver has a loop limit (lavapipe), the light
// samples are split over dispatches (gpu/loop_limit.h); elsewhere all run in one.
#include "penumbra/gpu/loop_limit.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/light_fans_gpu.h"

namespace penumbra {
namespace {

class ReferenceGpu final : public GpuShadowMethod {
 public:
  explicit ReferenceGpu(const ParamSet& p) : area_(p.get_string("sampling") == "area") {}

  void prepare(const ShadowContext&, GpuFrame& frame) override {
    stats_.prepare_count++;
    rays_ = gpu::Buffer(*frame.device, 2 * sizeof(uint64_t), "reference's ray counter");
  }
  // Nothing prepared: every evaluate() traces the geometry as the GPU holds it now.
  bool keeps_prepared_after_moving(std::span<const uint32_t>) override { return true; }
  bool computes_irradiance() const override { return true; }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    gpu::CommandList& cl = *frame.commands;
    cl.fill(rays_, 0);
    cl.stage("trace");
    shader::ReferenceFansParams p{};
    p.fans = light_fans_params(ctx, frame, ctx.light_samples, area_, rays_.address());
    p.fans.visibility = out.visibility;
    p.fans.irradiance = out.irradiance;
    p.canary = gpu::kLoopLimitCanary;
    const int n = p.fans.n;
    uint64_t traced = 0;
    split_.execute(
        n, "reference", frame.device->info().name,
        [&](int first, int count) {
          if (count < n) gpu::ensure_buffer(*frame.device, partial_, uint64_t(frame.slots) * 12, "reference's partial sums");
          p.partial = partial_.address();
          p.first = first;
          p.count = count;
          cl.dispatch("reference_fans", frame.slots, p);
        },
        [&] {
          // Whether a thread was cut short is only known once the dispatches ran.
          frame.flush();
          const std::vector<uint64_t> counts = rays_.download_vector<uint64_t>(2);
          if (counts[1] == 0) {
            traced = counts[0];
            return false;
          }
          cl.fill(rays_, 0);
          cl.stage("trace");
          return true;
        });
    stats_.rays_traced += traced;
  }

 private:
  bool area_;
  gpu::LoopLimitSplit split_;
  gpu::Buffer rays_, partial_;
};

// The counters, and the partial sums per view-sample slot where the samples are split.
MemoryEstimate memory(const ParamSet&, const MemoryQuery& q) {
  MemoryTally tally;
  tally.add(std::max<uint64_t>(q.view_samples, 1) * 12 + 2 * sizeof(uint64_t), kViewSamplesSetting);
  return tally.estimate();
}

const GpuMethodRegistration registration({"reference", [](const ParamSet& p) { return std::make_unique<ReferenceGpu>(p); },
                                          memory});

}  // namespace
}  // namespace penumbra
