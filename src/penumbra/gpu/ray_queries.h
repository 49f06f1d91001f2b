// Rays given by the host, traced on the GPU: the GPU ray tracer's answer to arbitrary segments
// (transmittance) and rays (closest hits), for what the frame's kernels do not cover: tests that
// hold the GPU tracer against Embree ray for ray, and the exactness checks of the methods that
// decide visibility per light point (trace-to-points, sintorn2008's afsm). One submission each.
#pragma once

#include <span>
#include <vector>

#include "penumbra/gpu/gpu_scene.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra::gpu {

// The transmittance along each segment (RayTracer::transmittance's rules: 0 at an opaque hit,
// (1 - opacity) per semi-transparent surface crossed).
std::vector<float> trace_transmittance(const GpuScene& scene, std::span<const ShadowRay> rays);

// The nearest hit of each ray that a camera ray stops at (alpha masks let it through), as
// RayTracer::intersect reports it: object = Hit::kMiss where nothing was hit; ng is not filled.
std::vector<Hit> trace_closest(const GpuScene& scene, std::span<const Ray> rays);

}  // namespace penumbra::gpu
