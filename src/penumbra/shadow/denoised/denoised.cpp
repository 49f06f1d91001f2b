// Method `rt-denoised`: few-sample ray-traced shadows and a denoiser, the real-time
// practice the paper methods compete with. Per view sample, `samples` light samples drawn
// exactly as `reference` draws them (shadow_rays.h, trace_light_fans), then:
//   - the ratio estimator of Heitz et al. 2018 (§3): the unshadowed irradiance is analytic and
//     only the visibility ratio is stochastic. With the same samples, S = sum T_i f_i / N
//     (shadowed) and U = sum f_i / N (unshadowed) are estimated and denoised with the same
//     weights, and E = (S' / U') x the closed-form unshadowed irradiance (§3.2: the ratio of
//     the denoised estimates, not the denoised ratio; computes_irradiance() true);
//   - V, the fraction of the light's area seen (every method's V: samples behind a closed
//     receiver's tangent plane count as blocked), is the same samples' area-weighted estimate
//     A, denoised with the same weights: S' / U' weighs the light by the cosine and leaves out
//     what lies behind the tangent plane, so it is not that fraction (docs/methods/rt-denoised.md,
//     "Which V");
//   - SVGF's spatial filter (Schied et al. 2017 §4.2-4.3; no temporal part: every frame is
//     filtered alone): an a-trous wavelet with the 5x5 B3 kernel, taps 2^i apart, edge-
//     stopping weights from depth (with its screen-space gradient), shading normal and V,
//     the latter scaled by V's variance, estimated from the pixel's own samples or, below 4
//     samples, spatially (§4.1). atrous_filter.h.
// The view samples are filtered as one image per camera ray index (`sub`): each layer holds
// one sample per pixel, so supersampled renders filter every sub-pixel ray among its own
// kind. docs/methods/rt-denoised.md.
#include <algorithm>
#include <cmath>

#include "penumbra/core/parallel.h"
#include "penumbra/shadow/denoised/atrous_filter.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/shadow/shadow_rays.h"

namespace penumbra {
namespace {

class DenoisedMethod final : public ShadowMethod {
 public:
  explicit DenoisedMethod(const ParamSet& p)
      : samples_(p.get_int("samples")), settings_(denoise::atrous_settings_from(p)) {}

  void prepare(const ShadowContext&) override { stats_.prepare_count++; }
  // E = the denoised ratio times the closed-form unshadowed irradiance; V is the area fraction.
  bool computes_irradiance() const override { return true; }
  // Nothing prepared: every evaluate() traces the geometry as the tracer holds it now.
  bool keeps_prepared_after_moving(std::span<const uint32_t>, const ShadowContext&) override { return true; }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    const PixelWindow window = vs.traced_window();
    const int layers = std::max(1, vs.samples_per_pixel);
    std::vector<denoise::GuidedImage> images(layers);
    for (denoise::GuidedImage& img : images) img.resize(window.width(), window.height());
    auto pixel_of = [&](const ViewSample& s) {
      const int x = static_cast<int>(s.pixel % static_cast<uint32_t>(vs.width)) - window.x0;
      const int y = static_cast<int>(s.pixel / static_cast<uint32_t>(vs.width)) - window.y0;
      return images[0].index(x, y);
    };
    const Camera& camera = ctx.scene->camera;
    const Vec3f forward = normalize(camera.target - camera.eye);
    {
      ScopedPhase phase(stats_, "trace");
      stats_.rays_traced += trace_light_fans(
          ctx, vs, samples_, LightSampling::SolidAngle, [&](size_t k, const LightFan& fan) {
            const ViewSample& s = vs.samples[k];
            // Heitz et al. 2018 §3: the shadowed and unshadowed estimates of the same samples,
            // and the variance of the ratio estimate R = sum T f / sum f (delta method, as for
            // self-normalised estimators): sum f_i^2 (T_i - R)^2 / (sum f_i)^2.
            shader::DenoiseFanSums sums = shader::dn_fan_begin();
            for (int i = 0; i < fan.count; ++i)
              shader::dn_fan_add(sums, fan.transmittance[i], fan.irradiance[i], fan.area_weight[i]);
            for (int i = 0; i < fan.count; ++i) shader::dn_fan_add_spread(sums, fan.transmittance[i], fan.irradiance[i]);
            const shader::DenoisePixel px = shader::dn_fan_pixel(sums, samples_);
            denoise::GuidedImage& img = images[std::min<uint32_t>(s.sub, layers - 1)];
            const size_t i = pixel_of(s);
            img.valid[i] = 1;
            img.depth[i] = shader::dn_view_depth(s.p, camera.eye, forward);
            img.normal[i] = s.ns;
            img.shadowed[i] = px.shadowed;
            img.unshadowed[i] = px.unshadowed;
            img.area[i] = px.area;
            img.variance[i] = px.variance;
          });
    }
    {
      ScopedPhase phase(stats_, "filter");
      for (denoise::GuidedImage& img : images) {
        if (samples_ < denoise::kMinSamplesForOwnVariance) denoise::estimate_variance_spatially(img, settings_);
        denoise::atrous_filter(img, settings_);
      }
    }
    const AreaLight& light = *ctx.light;
    parallel_for(vs.size(), 4096, [&](size_t begin, size_t end) {
      for (size_t k = begin; k < end; ++k) {
        const ViewSample& s = vs.samples[k];
        const denoise::GuidedImage& img = images[std::min<uint32_t>(s.sub, layers - 1)];
        const size_t i = pixel_of(s);
        out.visibility[k] = img.visibility(i);
        out.irradiance[k] = (light.radiance * light.unshadowed_irradiance_scalar(s.p, s.ns)) * img.ratio(i);
      }
    });
    stats_.extra["light_samples"] = samples_;
    stats_.extra["iterations"] = settings_.iterations;
  }

 private:
  int samples_;
  denoise::AtrousSettings settings_;
};

// One light's instance: per pixel of the traced window and camera ray index (at most one
// per view sample, but every pixel of the window counts: the images are dense), the guided
// image and the filter's scratch; per worker thread, one point's light samples.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  tally.add(q.view_samples * (denoise::GuidedImage::kBytesPerPixel + denoise::kScratchBytesPerPixel),
            kViewSamplesSetting);
  tally.add(static_cast<uint64_t>(q.threads) * light_fan_bytes(p.get_int("samples")), "samples");
  return tally.estimate();
}

const MethodRegistration registration({
    "rt-denoised",
    "1-8 ray-traced light samples per point, ratio estimator (Heitz 2018) and SVGF's a-trous filter (Schied 2017)",
    {
        {"samples", ParamType::Int, 4,
         "light samples per view sample (the method's own count: --spp does not apply)", {}, 1, 8},
        {"iterations", ParamType::Int, 5, "a-trous iterations (taps 2^i apart; SVGF §4.2: 5); 0: no filter", {}, 0, 10},
        {"sigma_z", ParamType::Float, 1.0, "depth weight (SVGF eq. 3): larger lets more across depth changes", {}, 1e-3,
         1e3},
        {"sigma_n", ParamType::Float, 128.0, "normal weight exponent (SVGF eq. 4): larger stops more at creases", {}, 0,
         1024},
        {"sigma_l", ParamType::Float, 4.0, "visibility weight (SVGF eq. 5), in standard deviations of V", {}, 1e-3, 1e3},
    },
    [](const ParamSet& p) { return std::make_unique<DenoisedMethod>(p); },
    // Its own `samples`, 1-8: at --spp's defaults (256) it would be the reference, not a
    // real-time estimate.
    /*samples_light=*/false,
    memory,
    // The filter reads neighbouring pixels: a crop's border pixels miss the ones outside it.
    /*tile_exact=*/false,
    /*uniform_light=*/false,
    // Its rays sample a sphere toward each point (shadow_rays.h), as the reference does.
    /*sphere_through_disk=*/false,
});

}  // namespace
}  // namespace penumbra
