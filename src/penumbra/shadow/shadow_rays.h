// Shadow-ray passes over all view samples that several methods share.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "penumbra/core/sampling.h"
#include "penumbra/scene/light_batch.h"
#include "penumbra/shadow/view_samples.h"

namespace penumbra {

class RayTracer;
struct ShadowContext;

// Transmittance of the segment from every view sample to the point `target` (the light's
// centre for hard shadows): rtcOccluded1M streams of 256 rays, parallel over samples.
// out[i] is 0 where opaque geometry blocks the segment, 1 where nothing does, and the
// product of (1 - opacity) through semi-transparent casters otherwise.
void transmittance_to_point(const RayTracer& tracer, const ViewSamples& samples, Vec3f target, std::span<float> out);

// How the light's samples are drawn toward a point (reference.md): over solid angle
// (spherical rectangles, Urena et al. 2013; cones for spheres; area for disks) or uniformly
// over the light's area.
enum class LightSampling { SolidAngle, Area };

// One view sample's shadow-ray fan: `count` light samples, i < count, with
//   transmittance[i]  T_i, 1 where nothing blocks the ray, 0 where an opaque caster does;
//   irradiance[i]     f_i, its unshadowed contribution to E / L (cos(n, w_i) / pdf_i, or the
//                     area form cos cos_l A / d^2): E = L/N sum_i T_i f_i with N the samples
//                     drawn (count may be lower where some fall behind the point);
//   area_weight[i]    a_i, area density over solid-angle density: V = sum T_i a_i / sum a_i is
//                     the fraction of the light's area the point sees (1 where unoccluded).
struct LightFan {
  int count = 0;
  const float* transmittance = nullptr;
  const float* irradiance = nullptr;
  const float* area_weight = nullptr;
};

// The reference's light sampling (reference.md) for every view sample: `n` stratified samples
// of ctx.light per view sample, keyed by (ctx.seed, light, camera ray, ctx.frame) so that they
// do not depend on the thread count or the rendered window, traced as one Embree stream
// (RayTracer::transmittance_fan). Calls visit(k, fan) for view sample k, in parallel over k
// (each k once); advances ctx.progress. Returns the number of shadow rays traced. Methods that
// draw the same n get the very samples `reference` draws.
uint64_t trace_light_fans(const ShadowContext& ctx, const ViewSamples& samples, int n, LightSampling sampling,
                          const std::function<void(size_t, const LightFan&)>& visit);
// Bytes trace_light_fans holds per worker thread for n samples.
uint64_t light_fan_bytes(int n);

// One view sample's light samples as trace_light_fans draws them, before they are traced: the
// buffers (reused from point to point) and the drawing itself. For the code that traces the
// same rays elsewhere (the GPU tracer's tests compare it with Embree ray for ray).
struct LightFanDraw {
  std::vector<float> ux, uy;  // the stratified points on [0,1)^2, padded (LightSampleBatch)
  LightSampleBatch batch;     // x, y, z: the vector from the point to each light sample
  std::vector<float> cosine;  // f_i of LightFan
  explicit LightFanDraw(int n);
};
// Draws view sample s's fan into `draw` (keyed by ctx's seed, light and frame); returns how many
// samples it kept (the first `count` of draw.batch and draw.cosine).
int draw_light_fan(const ShadowContext& ctx, const ViewSample& s, int n, const StratifiedGrid& grid,
                   LightSampling sampling, LightFanDraw& draw);

}  // namespace penumbra
