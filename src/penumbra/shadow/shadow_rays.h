// Shadow-ray passes over all view samples that several methods share.
#pragma once

#include <span>

#include "penumbra/shadow/view_samples.h"

namespace penumbra {

class RayTracer;

// Transmittance of the segment from every view sample to the point `target` (the light's
// centre for hard shadows): rtcOccluded1M streams of 256 rays, parallel over samples.
// out[i] is 0 where opaque geometry blocks the segment, 1 where nothing does, and the
// product of (1 - opacity) through semi-transparent casters otherwise.
void transmittance_to_point(const RayTracer& tracer, const ViewSamples& samples, Vec3f target, std::span<float> out);

}  // namespace penumbra
