// Method `hard`: one shadow ray from each view sample to the light's centre. The hard
// shadow of a point light; the cost floor every soft method is compared with.
#include "penumbra/core/parallel.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {

class HardShadows final : public ShadowMethod {
 public:
  void prepare(const ShadowContext&) override { stats_.prepare_count++; }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    ScopedPhase phase(stats_, "trace");
    const Vec3f c = ctx.light->center;
    parallel_for(vs.size(), 1024, [&](size_t begin, size_t end) {
      constexpr size_t kBatch = 256;
      ShadowRay rays[kBatch];
      for (size_t b = begin; b < end; b += kBatch) {
        size_t n = std::min(kBatch, end - b);
        for (size_t i = 0; i < n; ++i) rays[i] = shadow_ray_to(vs.samples[b + i].p, vs.samples[b + i].ng, c);
        ctx.tracer->transmittance(std::span<const ShadowRay>(rays, n), out.visibility.subspan(b, n));
      }
    });
    stats_.rays_traced += vs.size();
  }
};

const MethodRegistration registration({
    "hard",
    "hard shadows: one shadow ray to the light centre",
    {},
    [](const ParamSet&) { return std::make_unique<HardShadows>(); },
});

}  // namespace
}  // namespace penumbra
