// `reference` on the GPU: the CPU version's estimators and light samples (reference.cpp), one
// thread per view sample tracing its n shadow rays through the GPU's BVH
// (kernels/reference_fans.comp). At one seed and spp it traces the CPU's rays up to float
// rounding (gpu_reference_test.cpp).
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/light_fans_gpu.h"

namespace penumbra {
namespace {

class ReferenceGpu final : public GpuShadowMethod {
 public:
  explicit ReferenceGpu(const ParamSet& p) : area_(p.get_string("sampling") == "area") {}

  void prepare(const ShadowContext&, GpuFrame& frame) override {
    stats_.prepare_count++;
    rays_ = gpu::Buffer(*frame.device, sizeof(uint64_t), "reference's ray counter");
  }
  // Nothing prepared: every evaluate() traces the geometry as the GPU holds it now.
  bool keeps_prepared_after_moving(std::span<const uint32_t>) override { return true; }
  bool computes_irradiance() const override { return true; }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    gpu::CommandList& cl = *frame.commands;
    cl.fill(rays_, 0);
    cl.stage("trace");
    shader::LightFansParams p = light_fans_params(ctx, frame, ctx.light_samples, area_, rays_.address());
    p.visibility = out.visibility;
    p.irradiance = out.irradiance;
    cl.dispatch("reference_fans", frame.slots, p);
    // The count is read once the frame has run (collect_stats).
    pending_ = true;
  }

  void collect_stats() override {
    if (!pending_) return;
    stats_.rays_traced += rays_.download_vector<uint64_t>(1)[0];
    pending_ = false;
  }

 private:
  bool area_;
  bool pending_ = false;
  gpu::Buffer rays_;
};

const GpuMethodRegistration registration({"reference", [](const ParamSet& p) { return std::make_unique<ReferenceGpu>(p); },
                                          /*estimate_memory=*/{}});

}  // namespace
}  // namespace penumbra
