// Method `hard`: one shadow ray from each view sample to the light's centre. The hard
// shadow of a point light; the cost floor every soft method is compared with.
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/shadow/shadow_rays.h"

namespace penumbra {
namespace {

class HardShadows final : public ShadowMethod {
 public:
  void prepare(const ShadowContext&) override { stats_.prepare_count++; }
  // Nothing prepared: every evaluate() traces the geometry as the tracer holds it now.
  bool keeps_prepared_after_moving(std::span<const uint32_t>, const ShadowContext&) override { return true; }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    ScopedPhase phase(stats_, "trace");
    transmittance_to_point(*ctx.tracer, vs, ctx.light->center, out.visibility);
    stats_.rays_traced += vs.size();
  }
};

const MethodRegistration registration({
    "hard",
    "hard shadows: one shadow ray to the light centre",
    {},
    [](const ParamSet&) { return std::make_unique<HardShadows>(); },
    /*samples_light=*/false,
    // No estimate: its rays go in streams of 256 on the stack; nothing grows with a setting.
    /*estimate_memory=*/{},
    /*tile_exact=*/true,
    // A textured light counts as its mean colour: the light is its centre, size or outline.
    /*uniform_light=*/true,
    // The centre alone: a sphere split into faces would give the same rays.
    /*sphere_through_disk=*/false,
});

}  // namespace
}  // namespace penumbra
