// Method `reference`: the ground truth every method is measured against. Stochastic ray
// tracing of the real geometry on Embree: N stratified light samples per view sample, warped
// together by SIMD kernels (scene/light_batch.h), their shadow rays written straight into
// Embree's rtcOccluded1M streams (RayTracer::transmittance_fan), semi-transparent casters
// attenuating by (1 - opacity) per crossing.
//
// Estimators (per view sample p with shading normal n, light samples i = 1..N):
//   solid-angle sampling (default): directions w_i with density pdf_i over solid angle
//     (spherical rectangles, Urena et al. 2013; cones for spheres; area for disks),
//     E = L/N sum_i T_i cos(n, w_i) / pdf_i                                  (eq. 1)
//     V = sum_i T_i a_i / sum_i a_i, a_i = (area density)/(solid-angle density) (eq. 2:
//     the self-normalised estimate of the fraction of the light's *area* p sees, which
//     is exactly 1 for an unoccluded point, whatever N).
//   area sampling: points q_i uniform on the light's area; V = mean T_i and
//     E = L A/N sum_i T_i cos(n, w_i) cos_l / |q_i - p|^2.
#include <algorithm>

#include "penumbra/shadow/shadow_method.h"
#include "penumbra/shadow/shadow_rays.h"

namespace penumbra {
namespace {

class ReferenceMethod final : public ShadowMethod {
 public:
  explicit ReferenceMethod(const ParamSet& p) : solid_angle_(p.get_string("sampling") == "solid-angle") {}

  void prepare(const ShadowContext&) override { stats_.prepare_count++; }
  // Nothing prepared: every evaluate() traces the geometry as the tracer holds it now.
  bool keeps_prepared_after_moving(std::span<const uint32_t>, const ShadowContext&) override { return true; }
  bool computes_irradiance() const override { return true; }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    ScopedPhase phase(stats_, "trace");
    const Vec3f radiance = ctx.light->radiance;
    const int n = std::max(1, ctx.light_samples);
    // The sampling itself is shared (shadow_rays.h): rt-denoised draws the same fans.
    stats_.rays_traced += trace_light_fans(ctx, vs, n, solid_angle_ ? LightSampling::SolidAngle : LightSampling::Area,
                                           [&](size_t k, const LightFan& fan) {
                                             double e = 0, v = 0, wsum = 0;
                                             for (int i = 0; i < fan.count; ++i) {
                                               e += fan.transmittance[i] * fan.irradiance[i];
                                               v += fan.transmittance[i] * fan.area_weight[i];
                                               wsum += fan.area_weight[i];
                                             }
                                             out.visibility[k] = wsum > 0 ? static_cast<float>(v / wsum) : 0.0f;
                                             out.irradiance[k] = radiance * static_cast<float>(e / n);
                                           });
  }

 private:
  bool solid_angle_;
};

// One light's instance: per worker thread, one point's light samples (the batch and the
// four arrays beside it); nothing is kept between calls.
MemoryEstimate memory(const ParamSet&, const MemoryQuery& q) {
  MemoryTally tally;
  tally.add(static_cast<uint64_t>(q.threads) * light_fan_bytes(q.light_samples), kLightSamplesSetting);
  return tally.estimate();
}

const MethodRegistration registration({
    "reference",
    "ground truth: stochastic ray tracing of the real geometry on Embree (--spp shadow rays per point)",
    {{"sampling", ParamType::String, "solid-angle",
      "how light samples are drawn: 'solid-angle' (spherical rectangles / cones; lower variance) or 'area'",
      {"solid-angle", "area"}}},
    [](const ParamSet& p) { return std::make_unique<ReferenceMethod>(p); },
    /*samples_light=*/true,
    memory,
    /*tile_exact=*/true,
    /*uniform_light=*/false,
    // Its rays sample a sphere toward each point (the cone of its silhouette).
    /*sphere_through_disk=*/false,
});

}  // namespace
}  // namespace penumbra
