// `hard` on the GPU: one shadow segment per view sample to the light's centre
// (kernels/hard_rays.comp), as hard.cpp traces it with Embree.
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/shadow_rays_shared.h"

namespace penumbra {
namespace {

class HardShadowsGpu final : public GpuShadowMethod {
 public:
  void prepare(const ShadowContext&, GpuFrame&) override { stats_.prepare_count++; }
  // Nothing prepared: every evaluate() traces the geometry as the GPU holds it now.
  bool keeps_prepared_after_moving(std::span<const uint32_t>) override { return true; }

  void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) override {
    frame.commands->stage("trace");
    frame.commands->dispatch("hard_rays", frame.slots,
                             shader::PointRaysParams{frame.scene->address(), frame.view_samples, out.visibility,
                                                     ctx.light->center, frame.slots});
  }
};

const GpuMethodRegistration registration({"hard", [](const ParamSet&) { return std::make_unique<HardShadowsGpu>(); },
                                          /*estimate_memory=*/{}});

}  // namespace
}  // namespace penumbra
