#include "penumbra/shadow/shadow_rays.h"

#include <algorithm>

#include "penumbra/core/parallel.h"
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

}  // namespace penumbra
