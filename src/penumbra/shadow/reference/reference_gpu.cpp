// `reference` on the GPU: the CPU version's estimators and light samples (reference.cpp), one
// thread per view sample tracing its n shadow rays through the GPU's BVH
// (kernels/reference_fans.comp). At one seed and spp it traces the CPU's rays up to float
// rounding (gpu_reference_test.cpp).
#include "penumbra/core/sampling.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/shadow_rays_shared.h"

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
    const int n = std::max(1, ctx.light_samples);
    const StratifiedGrid grid(n);
    gpu::CommandList& cl = *frame.commands;
    cl.fill(rays_, 0);
    cl.stage("trace");
    shader::LightFansParams p{};
    p.scene = frame.scene->address();
    p.samples = frame.view_samples;
    p.light = frame.light;
    p.visibility = out.visibility;
    p.irradiance = out.irradiance;
    p.rays = rays_.address();
    p.seed = ctx.seed;
    p.slots = frame.slots;
    p.light_index = ctx.light_index;
    p.frame = ctx.frame;
    p.n = n;
    p.grid_cols = grid.cols();
    p.inv_cols = grid.inv_cols();
    p.inv_rows = grid.inv_rows();
    p.area_sampling = area_ ? 1u : 0u;
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
