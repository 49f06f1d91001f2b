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
#include <vector>

#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/sampling.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/trace/ray_tracer.h"

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
    const AreaLight& light = *ctx.light;
    const int n = std::max(1, ctx.light_samples);
    std::atomic<uint64_t> rays{0};
    const StratifiedGrid grid(n);
    parallel_for(vs.size(), 16, [&](size_t begin, size_t end) {
      // Per task: the light samples of one point in structure-of-arrays form, warped by the
      // SIMD kernels of scene/light_batch.h and traced as one fan (RayTracer::transmittance_fan).
      const size_t padded = LightSampleBatch::padded(n);
      std::vector<float> ux(padded, 0.0f), uy(padded, 0.0f), transmit(padded), cosine(padded);
      LightSampleBatch batch;
      batch.resize(n);
      uint64_t local_rays = 0;
      for (size_t k = begin; k < end; ++k) {
        const ViewSample& s = vs.samples[k];
        // Keyed by (seed, light, camera ray, frame): independent of the thread count and of
        // which pixels are rendered (a crop draws the whole frame's samples).
        Rng rng(ctx.seed, 0x52454600u + ctx.light_index, sample_key(s), ctx.frame);
        for (int i = 0; i < n; ++i) {
          const Vec2f u = grid.sample(i, rng.next_2d());
          ux[i] = u.x;
          uy[i] = u.y;
        }
        const LightPointSampler sampler(light, s.p);
        int m = 0;
        if (solid_angle_ && sampler.valid()) {
          m = sampler.sample_batch(ux.data(), uy.data(), n, batch);
          for (int i = 0; i < m; ++i) {
            const float cos_n = s.ns.x * batch.x[i] + s.ns.y * batch.y[i] + s.ns.z * batch.z[i];
            cosine[i] = std::max(0.0f, cos_n) / batch.dist[i] * batch.inv_pdf[i];
          }
        } else {
          // Area mode: the emitter's normal and area (a sphere's disk faces p: cos 1; an
          // ellipsoid's central ellipse toward p has its own plane).
          Vec3f emit_n = light.frame.n;
          float emit_area = light.area();
          if (light.shape == LightShape::Ellipsoid && light.faces(s.p)) {
            const AreaLight::Ellipse e = light.section_toward(s.p);
            emit_n = e.normal;
            emit_area = e.area;
          }
          for (int i = 0; i < n; ++i) {
            const Vec3f d = light.sample_area_toward({ux[i], uy[i]}, s.p) - s.p;
            const float dist2 = length_squared(d);
            const Vec3f w = d / std::sqrt(dist2);
            const float cos_l = light.shape == LightShape::Sphere      ? 1.0f
                                : light.shape == LightShape::Ellipsoid ? std::abs(dot(w, emit_n))
                                                                       : std::max(0.0f, -dot(w, light.frame.n));
            batch.x[i] = d.x;
            batch.y[i] = d.y;
            batch.z[i] = d.z;
            batch.area_weight[i] = 1.0f;
            cosine[i] = std::max(0.0f, dot(s.ns, w)) * cos_l * emit_area / dist2;
          }
          m = n;
        }
        ctx.tracer->transmittance_fan(s.p, s.ng, batch.x.data(), batch.y.data(), batch.z.data(), m, transmit.data());
        local_rays += m;
        double e = 0, v = 0, wsum = 0;
        for (int i = 0; i < m; ++i) {
          e += transmit[i] * cosine[i];
          v += transmit[i] * batch.area_weight[i];
          wsum += batch.area_weight[i];
        }
        out.visibility[k] = wsum > 0 ? static_cast<float>(v / wsum) : 0.0f;
        out.irradiance[k] = light.radiance * static_cast<float>(e / n);
      }
      rays += local_rays;
      if (ctx.progress) ctx.progress->add(end - begin);
    });
    stats_.rays_traced += rays.load();
  }

 private:
  bool solid_angle_;
};

// One light's instance: per worker thread, one point's light samples (the batch and the
// four arrays beside it); nothing is kept between calls.
MemoryEstimate memory(const ParamSet&, const MemoryQuery& q) {
  const int n = std::max(1, q.light_samples);
  MemoryTally tally;
  const uint64_t per_thread = LightSampleBatch::bytes(n) + 4 * LightSampleBatch::padded(n) * sizeof(float);
  tally.add(static_cast<uint64_t>(q.threads) * per_thread, kLightSamplesSetting);
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
});

}  // namespace
}  // namespace penumbra
