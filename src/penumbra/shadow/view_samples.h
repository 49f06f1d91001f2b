// The camera pass's output: one record per visible surface sample (a G-buffer in
// structure-of-records form). Every shadow method reads the same view samples, so
// methods can be compared pixel for pixel.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/scene/camera.h"
#include "penumbra/shadow/view_samples_shared.h"

namespace penumbra {

struct ViewSample {
  Vec3f p;       // world position
  Vec3f ng;      // geometric normal, facing the camera
  Vec3f ns;      // shading normal, in ng's hemisphere
  Vec3f albedo;  // zero for the back of a one-sided surface
  uint32_t object = 0;  // index into Scene::objects
  uint32_t prim = 0;    // triangle index within the object's mesh
  uint32_t pixel = 0;   // y * width + x in the whole image, whatever window was rendered
  uint32_t sub = 0;     // the camera ray's index within its pixel, 0 .. samples_per_pixel - 1
};
// A cache line each: the camera pass writes them straight to their place, and a renderer
// keeps the buffer from frame to frame.
static_assert(sizeof(ViewSample) == 64);
// The GPU's record has the same bytes (view_samples_shared.h).
static_assert(sizeof(ViewSample) == sizeof(shader::GpuViewSample) && offsetof(ViewSample, albedo) == 36 &&
              offsetof(ViewSample, object) == offsetof(shader::GpuViewSample, object) &&
              offsetof(ViewSample, sub) == offsetof(shader::GpuViewSample, sub));

// The key a method's random numbers for one view sample derive from: its camera ray (the
// global pixel and the ray's index within it), not its index in ViewSamples::samples, which
// depends on which pixels were rendered. So a tile of the image (RenderSettings::crop) draws
// the very samples the whole frame draws there.
inline uint64_t sample_key(const ViewSample& s) { return static_cast<uint64_t>(s.pixel) << 32 | s.sub; }

struct ViewSamples {
  int width = 0, height = 0;      // the whole image's, also when only a window was rendered
  PixelWindow window;             // the pixels the camera pass traced (the whole image, or a crop)
  int samples_per_pixel = 1;      // camera supersampling; misses count as background
  std::vector<ViewSample> samples;  // hits only, grouped by pixel in scanline order
  size_t size() const { return samples.size(); }
  // The window, or the whole image where none was recorded (samples made by hand in tests).
  PixelWindow traced_window() const { return window.empty() ? PixelWindow{0, 0, width, height} : window; }
};

}  // namespace penumbra
