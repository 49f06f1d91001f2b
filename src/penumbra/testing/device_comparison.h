// What the tests of a method's GPU version share (*_gpu_test.cpp): a shipped scene at a small
// size, the settings of one render on either device, and the mean absolute difference of two
// images, a render on both devices (issues 28-30 bound a GPU version's mean |dV| against its CPU
// version's). Header-only;
// used by *_test.cpp files only.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/eval/run_setup.h"
#include "penumbra/gpu/device.h"
#include "penumbra/render/renderer.h"

namespace penumbra::testing {

// scenes/NAME rendered at resolution x (its aspect) pixels.
inline Scene shipped_scene(const std::string& name, int resolution) {
  RunSetup setup = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name);
  setup.apply("resolution", std::to_string(resolution));
  return setup.load();
}

// One render of `method` with `params` at `seed` and `spp` light samples (0: the method's
// default), on the GPU or the CPU.
inline RenderSettings device_settings(const std::string& method, std::vector<std::string> params, bool gpu, int seed,
                                      int spp = 0) {
  RenderSettings s;
  s.method = method;
  s.params = std::move(params);
  s.seed = seed;
  if (spp > 0) s.light_samples = spp;
  if (gpu) s.device = gpu::DeviceChoice::parse("gpu");
  return s;
}

// The mean of |a - b| over every channel of every pixel.
inline double mean_abs_difference(const Image& a, const Image& b) {
  EXPECT_EQ(a.data().size(), b.data().size());
  double sum = 0;
  for (size_t i = 0; i < a.data().size() && i < b.data().size(); ++i) sum += std::abs(a.data()[i] - b.data()[i]);
  return a.data().empty() ? 0.0 : sum / static_cast<double>(a.data().size());
}

// The same render on the CPU and on the GPU (`settings.device` is set for each), and the mean |dV|
// between them. The CPU's picture must hold some shadow, or the comparison says nothing.
struct DevicePair {
  RenderResult cpu, gpu;
  double mean_dv = 0;
};
inline DevicePair render_on_both(const Scene& scene, RenderSettings settings, const std::string& gpu_name) {
  DevicePair r;
  settings.device = {};
  r.cpu = render_scene(scene, settings);
  settings.device = gpu::DeviceChoice::parse("gpu");
  r.gpu = render_scene(scene, settings);
  EXPECT_EQ(r.gpu.device, gpu_name);
  double shadow = 0;
  for (float v : r.cpu.visibility.data()) shadow += 1 - v;
  EXPECT_GT(shadow, 10) << "no shadow to compare";
  r.mean_dv = mean_abs_difference(r.cpu.visibility, r.gpu.visibility);
  return r;
}

}  // namespace penumbra::testing
