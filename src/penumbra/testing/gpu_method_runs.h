// A method's GPU version against its CPU version (docs/gpu.md, "Porting a method"): a shipped
// scene at a small resolution, the same settings on both devices, and mean |dV| over the image.
// Header-only; tests only (GpuTest fixtures: validation messages fail them).
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/eval/run_setup.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/gpu/raster/gpu_batch_rasterizer.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/gpu_method.h"

namespace penumbra::testing {

// scenes/NAME at `resolution` pixels across.
inline Scene shipped_scene(const std::string& name, int resolution) {
  RunSetup setup = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name);
  setup.apply("resolution", std::to_string(resolution));
  return setup.load();
}

// `method` with `params` at seed 7 and `light_samples` (--spp), on the GPU or the CPU.
inline RenderSettings device_settings(const std::string& method, std::vector<std::string> params, bool gpu,
                                      int light_samples = 16) {
  RenderSettings s;
  s.method = method;
  s.params = std::move(params);
  s.seed = 7;
  s.light_samples = light_samples;
  if (gpu) s.device = gpu::DeviceChoice::parse("gpu");
  return s;
}

inline double mean_abs_dv(const Image& a, const Image& b) {
  EXPECT_EQ(a.data().size(), b.data().size());
  if (a.data().size() != b.data().size() || a.data().empty()) return 1.0;
  double sum = 0;
  for (size_t i = 0; i < a.data().size(); ++i) sum += std::abs(a.data()[i] - b.data()[i]);
  return sum / static_cast<double>(a.data().size());
}

// A method without a GPU version (the first by name), for the tests of the one-line error that
// refuses it; empty once every method has one.
inline std::string cpu_only_method() {
  for (const MethodInfo* m : MethodRegistry::all())
    if (!find_gpu_method(m->name)) return m->name;
  return "";
}

// A fixture for one method's GPU version: its name, light samples (--spp) and default
// parameters; the GPU rasterizer's test settings are reset after each test.
class GpuMethodTest : public gpu::testing::GpuTest {
 protected:
  GpuMethodTest(std::string method, int light_samples, std::vector<std::string> params)
      : method_(std::move(method)), light_samples_(light_samples), params_(std::move(params)) {}
  void TearDown() override {
    gpu::GpuBatchRasterizer::set_batch_budget_for_testing(0);
    gpu::GpuBatchRasterizer::set_first_capacities_for_testing(0, 0);
    GpuTest::TearDown();
  }

  RenderSettings settings(bool gpu) const { return settings(gpu, params_); }
  RenderSettings settings(bool gpu, std::vector<std::string> params) const {
    return device_settings(method_, std::move(params), gpu, light_samples_);
  }

  // Renders `scene` with `settings` on both devices; returns mean |dV| (recorded as a test
  // property) and checks the CPU's picture has shadows to compare.
  double difference(const Scene& scene, RenderSettings settings, const std::string& property = "") {
    RenderSettings cpu_settings = settings;
    cpu_settings.device = {};
    if (!settings.device.gpu) settings.device = gpu::DeviceChoice::parse("gpu");
    const RenderResult cpu = render_scene(scene, cpu_settings);
    const RenderResult gpu = render_scene(scene, settings);
    EXPECT_EQ(gpu.device, device().info().name);
    double shadow = 0;
    for (float v : cpu.visibility.data()) shadow += 1 - v;
    EXPECT_GT(shadow, 10) << "no shadow to compare";
    const double d = mean_abs_dv(cpu.visibility, gpu.visibility);
    if (!property.empty()) {
      char text[32];
      std::snprintf(text, sizeof text, "%.2g", d);
      RecordProperty("mean_abs_dv_" + property, text);
    }
    return d;
  }

  // `scene` on both devices, expected to give the very same picture: the GPU's render.
  RenderResult expect_the_cpus_picture(const Scene& scene) {
    const RenderResult cpu = render_scene(scene, settings(false));
    RenderResult gpu = render_scene(scene, settings(true));
    EXPECT_EQ(mean_abs_dv(cpu.visibility, gpu.visibility), 0.0);
    return gpu;
  }

  // The crop `window` of `scene` on the GPU against the CPU's crop (mean |dV|, recorded as
  // mean_abs_dv_crop); where `tile_exact`, the crop's pixels also equal the whole frame's.
  double crop_difference(const Scene& scene, PixelWindow window, bool tile_exact) {
    RenderSettings crop = settings(true);
    crop.crop = window;
    const double d = difference(scene, crop, "crop");
    if (tile_exact) {
      const RenderResult part = render_scene(scene, crop);
      const RenderResult whole = render_scene(scene, settings(true));
      EXPECT_EQ(part.visibility.width(), window.width());
      EXPECT_EQ(part.visibility.height(), window.height());
      for (int y = 0; y < part.visibility.height(); ++y)
        for (int x = 0; x < part.visibility.width(); ++x)
          EXPECT_EQ(part.visibility.at(x, y, 0), whole.visibility.at(x + window.x0, y + window.y0, 0)) << x << " " << y;
    }
    return d;
  }

 private:
  std::string method_;
  int light_samples_;
  std::vector<std::string> params_;
};

}  // namespace penumbra::testing
