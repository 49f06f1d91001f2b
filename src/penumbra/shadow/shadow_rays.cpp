#include "penumbra/shadow/shadow_rays.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <vector>

#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"
#include "penumbra/scene/light_batch.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {

void transmittance_to_point(const RayTracer& tracer, const ViewSamples& vs, Vec3f target, std::span<float> out) {
  parallel_for(vs.size(), 1024, [&](size_t begin, size_t end) {
    constexpr size_t kBatch = 256;
    ShadowRay rays[kBatch];
    for (size_t b = begin; b < end; b += kBatch) {
      size_t n = std::min(kBatch, end - b);
      for (size_t i = 0; i < n; ++i) rays[i] = shadow_ray_to(vs.samples[b + i].p, vs.samples[b + i].ng, target);
      tracer.transmittance(std::span<const ShadowRay>(rays, n), out.subspan(b, n));
    }
  });
}

uint64_t light_fan_bytes(int n) {
  n = std::max(1, n);
  return LightSampleBatch::bytes(n) + 4 * LightSampleBatch::padded(n) * sizeof(float);
}

LightFanDraw::LightFanDraw(int n)
    : ux(LightSampleBatch::padded(n), 0.0f), uy(LightSampleBatch::padded(n), 0.0f), cosine(LightSampleBatch::padded(n)) {
  batch.resize(n);
}

int draw_light_fan(const ShadowContext& ctx, const ViewSample& s, int n, const StratifiedGrid& grid,
                   LightSampling sampling, LightFanDraw& draw) {
  const AreaLight& light = *ctx.light;
  // Keyed by (seed, light, camera ray, frame): independent of the thread count and of which
  // pixels are rendered (a crop draws the whole frame's samples).
  Rng rng(ctx.seed, 0x52454600u + ctx.light_index, sample_key(s), ctx.frame);
  for (int i = 0; i < n; ++i) {
    const Vec2f u = grid.sample(i, rng.next_2d());
    draw.ux[i] = u.x;
    draw.uy[i] = u.y;
  }
  LightSampleBatch& batch = draw.batch;
  const LightPointSampler sampler(light, s.p);
  if (sampling == LightSampling::SolidAngle && sampler.valid()) {
    const int m = sampler.sample_batch(draw.ux.data(), draw.uy.data(), n, batch);
    for (int i = 0; i < m; ++i) {
      const float cos_n = s.ns.x * batch.x[i] + s.ns.y * batch.y[i] + s.ns.z * batch.z[i];
      draw.cosine[i] = std::max(0.0f, cos_n) / batch.dist[i] * batch.inv_pdf[i];
    }
    return m;
  }
  // Area mode: the emitter's normal and area (a sphere's disk faces p: cos 1; an ellipsoid's
  // central ellipse toward p has its own plane).
  Vec3f emit_n = light.frame.n;
  float emit_area = light.area();
  if (light.shape == LightShape::Ellipsoid && light.faces(s.p)) {
    const AreaLight::Ellipse e = light.section_toward(s.p);
    emit_n = e.normal;
    emit_area = e.area;
  }
  for (int i = 0; i < n; ++i) {
    const Vec3f d = light.sample_area_toward({draw.ux[i], draw.uy[i]}, s.p) - s.p;
    const float dist2 = length_squared(d);
    const Vec3f w = d / std::sqrt(dist2);
    const float cos_l = light.shape == LightShape::Sphere      ? 1.0f
                        : light.shape == LightShape::Ellipsoid ? std::abs(dot(w, emit_n))
                                                               : std::max(0.0f, -dot(w, light.frame.n));
    batch.x[i] = d.x;
    batch.y[i] = d.y;
    batch.z[i] = d.z;
    batch.area_weight[i] = 1.0f;
    draw.cosine[i] = std::max(0.0f, dot(s.ns, w)) * cos_l * emit_area / dist2;
  }
  return n;
}

uint64_t trace_light_fans(const ShadowContext& ctx, const ViewSamples& vs, int n, LightSampling sampling,
                          const std::function<void(size_t, const LightFan&)>& visit) {
  n = std::max(1, n);
  std::atomic<uint64_t> rays{0};
  const StratifiedGrid grid(n);
  parallel_for(vs.size(), 16, [&](size_t begin, size_t end) {
    // Per task: the light samples of one point in structure-of-arrays form, warped by the
    // SIMD kernels of scene/light_batch.h and traced as one fan (RayTracer::transmittance_fan).
    LightFanDraw draw(n);
    std::vector<float> transmit(LightSampleBatch::padded(n));
    uint64_t local_rays = 0;
    for (size_t k = begin; k < end; ++k) {
      const ViewSample& s = vs.samples[k];
      const int m = draw_light_fan(ctx, s, n, grid, sampling, draw);
      ctx.tracer->transmittance_fan(s.p, s.ng, draw.batch.x.data(), draw.batch.y.data(), draw.batch.z.data(), m,
                                    transmit.data());
      local_rays += m;
      visit(k, LightFan{m, transmit.data(), draw.cosine.data(), draw.batch.area_weight.data()});
    }
    rays += local_rays;
    if (ctx.progress) ctx.progress->add(end - begin);
  });
  return rays.load();
}

}  // namespace penumbra
