// The camera pass's output: one record per visible surface sample (a G-buffer in
// structure-of-records form). Every shadow method reads the same view samples, so
// methods can be compared pixel for pixel.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"

namespace penumbra {

struct ViewSample {
  Vec3f p;       // world position
  Vec3f ng;      // geometric normal, facing the camera
  Vec3f ns;      // shading normal, in ng's hemisphere
  Vec3f albedo;  // zero for the back of a one-sided surface
  uint32_t object = 0;  // index into Scene::objects
  uint32_t prim = 0;    // triangle index within the object's mesh
  uint32_t pixel = 0;   // y * width + x
};

struct ViewSamples {
  int width = 0, height = 0;
  int samples_per_pixel = 1;      // camera supersampling; misses count as background
  std::vector<ViewSample> samples;  // hits only, grouped by pixel in scanline order
  size_t size() const { return samples.size(); }
};

}  // namespace penumbra
