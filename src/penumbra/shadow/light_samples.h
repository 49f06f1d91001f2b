// One set of N light points shared by every view sample of a frame (agrawala2000 §3,
// sintorn2008 §4.2, Laine et al. 2005 §3: the light samples are fixed, not drawn per point),
// for the methods that decide visibility exactly per light sample (afsm, ssv-rt): they use
// the very same points, so their results can be compared sample for sample with each other
// and with Embree rays to those points.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/scene/light.h"

namespace penumbra {

// The N light points of one frame: stratified on [0,1)^2 (LightSampleSet, fixed for every
// view sample), mapped by AreaLight::sample_area.
struct LightSamples {
  std::vector<Vec3f> points;  // world space
  std::vector<Vec2f> local;   // (q - c) . (s, t) / radius
  Vec3f center, s, t, n;      // the light's centre and frame
  float radius = 1;           // AreaLight::extent_radius()
  int size() const { return static_cast<int>(points.size()); }
};
// Frame `frame`'s samples of light `light_index` (keyed by seed, light and frame only; the
// key is afsm's, where the set was first used). n >= 1.
LightSamples make_light_samples(const AreaLight& light, int n, uint64_t seed, int light_index, int frame);
// What make_light_samples allocates for n samples (both arrays grown by doubling).
inline uint64_t light_samples_bytes(int n) { return 2 * static_cast<uint64_t>(n) * (sizeof(Vec3f) + sizeof(Vec2f)); }

}  // namespace penumbra
