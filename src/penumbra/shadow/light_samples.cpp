#include "penumbra/shadow/light_samples.h"

#include <algorithm>

#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"

namespace penumbra {

LightSamples make_light_samples(const AreaLight& light, int n, uint64_t seed, int light_index, int frame) {
  n = std::max(1, n);
  LightSamples out;
  out.center = light.center;
  out.s = light.frame.s;
  out.t = light.frame.t;
  out.n = light.frame.n;
  out.radius = std::max(light.extent_radius(), 1e-20f);
  const LightSampleSet set(n, hash_combine(hash_combine(seed, 0x4146534du /* "AFSM" */ + light_index), frame),
                           /*per_pixel=*/false);
  const float inv_r = 1.0f / out.radius;
  for (int i = 0; i < n; ++i) {
    const Vec3f q = light.sample_area(set.sample(i, 0));
    out.points.push_back(q);
    const Vec3f d = q - out.center;
    out.local.push_back({dot(d, out.s) * inv_r, dot(d, out.t) * inv_r});
  }
  return out;
}

}  // namespace penumbra
