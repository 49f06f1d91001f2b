// A method's GPU version against its CPU version (issues 29, 30: mean |dV| at most 2e-3 at the
// same seed and spp on the shipped scenes): the scene at a small size, the same render on both
// devices, and their difference. Header-only; tests only.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/eval/run_setup.h"
#include "penumbra/gpu/device.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/gpu/raster/gpu_batch_rasterizer.h"
#include "penumbra/gpu/ray_queries.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/testing/method_runs.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra::testing {

// scenes/NAME (NAME with its .json) at `resolution` pixels along the longer side.
inline Scene shipped_scene(const std::string& name, int resolution) {
  RunSetup setup = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name);
  setup.apply("resolution", std::to_string(resolution));
  return setup.load();
}

// light_samples: 0 keeps the render's default.
inline RenderSettings device_settings(const std::string& method, std::vector<std::string> params, bool gpu,
                                      uint64_t seed = 7, int light_samples = 0) {
  RenderSettings s;
  s.method = method;
  s.params = std::move(params);
  s.seed = seed;
  if (light_samples > 0) s.light_samples = light_samples;
  if (gpu) s.device = gpu::DeviceChoice::parse("gpu");
  return s;
}

inline double mean_abs_dv(const Image& a, const Image& b) {
  EXPECT_EQ(a.data().size(), b.data().size());
  if (a.data().size() != b.data().size()) return 1.0;
  double sum = 0;
  for (size_t i = 0; i < a.data().size(); ++i) sum += std::abs(a.data()[i] - b.data()[i]);
  return a.data().empty() ? 0.0 : sum / static_cast<double>(a.data().size());
}

// The same render on both devices.
struct DevicePair {
  RenderResult cpu, gpu;
  double mean_abs_dv = 0;
  double cpu_shadow = 0;  // sum of 1 - V over the CPU's pixels: is there a shadow to compare?
};
// `settings` on the CPU and on the GPU (its device set for each).
inline DevicePair render_on_both(const Scene& scene, RenderSettings settings) {
  DevicePair p;
  settings.device = {};
  p.cpu = render_scene(scene, settings);
  settings.device = gpu::DeviceChoice::parse("gpu");
  p.gpu = render_scene(scene, settings);
  p.mean_abs_dv = mean_abs_dv(p.cpu.visibility, p.gpu.visibility);
  for (float v : p.cpu.visibility.data()) p.cpu_shadow += 1 - v;
  return p;
}
inline DevicePair render_on_both(const Scene& scene, const std::string& method, const std::vector<std::string>& params) {
  return render_on_both(scene, device_settings(method, params, false));
}

// V per view sample of the CPU's camera pass `r` (spp 1: one view sample per pixel) from a
// render of the same scene.
inline std::vector<float> per_sample(const SceneRun& r, const RenderResult& render) {
  std::vector<float> v(r.vs.size());
  for (size_t k = 0; k < v.size(); ++k) v[k] = render.visibility.data()[r.vs.samples[k].pixel];
  return v;
}

// The GPU ray tracer's fraction of `points` each view sample of `r` sees (embree_to_points'
// rays, traced by gpu::trace_transmittance): the exactness check of the methods that decide
// visibility per fixed light point (afsm, ssv-rt).
inline std::vector<float> gpu_rays_to_points(gpu::Device& device, const SceneRun& r, const std::vector<Vec3f>& points) {
  const AreaLight& light = r.scene.lights[0];
  std::vector<ShadowRay> rays;
  rays.reserve(r.vs.size() * points.size());
  for (const ViewSample& s : r.vs.samples)
    for (const Vec3f& q : points) rays.push_back(shadow_ray_to(s.p, s.ng, q));
  const gpu::GpuScene scene(device, r.scene);
  const std::vector<float> t = gpu::trace_transmittance(scene, rays);
  std::vector<float> v(r.vs.size(), 0.0f);
  for (size_t k = 0; k < v.size(); ++k) {
    if (!in_front(light, r.vs.samples[k].p)) continue;
    double sum = 0;
    for (size_t i = 0; i < points.size(); ++i) sum += t[k * points.size() + i];
    v[k] = static_cast<float>(sum / points.size());
  }
  return v;
}

// A ground under a light facing up, away from it: no view sample is in front of the light.
inline Scene light_facing_away_scene() {
  Scene scene;
  scene.objects.push_back(object(quad_y(0, -2, 2, -2, 2)));
  AreaLight light = rect_light_down({0, 1, 0}, 0.5f, 0.5f);
  light.frame = Frame::from_zx({0, 1, 0}, {1, 0, 0});
  scene.lights.push_back(light);
  scene.camera = top_camera(16);
  scene.finalize();
  return scene;
}

// light_facing_away_scene seen from nearer, so that every pixel shows the ground (a pixel
// without a surface counts as lit).
inline Scene facing_away_ground_only() {
  Scene scene = light_facing_away_scene();
  scene.camera = top_camera(16, 2.0f);
  return scene;
}

// The camera moved a fraction `t` of the way toward its target: other view samples, the same
// light-space structures for the methods that keep them.
inline Camera moved_camera(const Camera& c, float t) {
  Camera m = c;
  m.eye = c.eye + (c.target - c.eye) * t;
  return m;
}

// A fresh render of `scene` seen through `camera` on the CPU.
inline RenderResult cpu_render_with_camera(Scene scene, const Camera& camera, const std::string& method,
                                           const std::vector<std::string>& params) {
  scene.camera = camera;
  return render_scene(scene, device_settings(method, params, false));
}

// The GPU version's device-memory estimate of `method` at `params` on `scene` for `view_samples`
// camera rays (GpuMethodInfo::estimate_memory); a failure where it has none.
inline MemoryEstimate gpu_memory_estimate(const std::string& method, const Scene& scene,
                                          const std::vector<std::string>& params, uint64_t view_samples) {
  const GpuMethodInfo* info = find_gpu_method(method);
  EXPECT_NE(info, nullptr) << method;
  if (!info) return {};
  EXPECT_TRUE(info->estimate_memory) << method;
  if (!info->estimate_memory) return {};
  MemoryQuery q;
  q.triangles = scene.triangle_count();
  q.view_samples = view_samples;
  return info->estimate_memory(resolve_method_params(method, scene, params), q);
}

// A mean |dV| as a test property (gtest XML): "1.2e-05".
inline std::string dv_text(double dv) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1e", dv);
  return buf;
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
    RenderSettings s = device_settings(method_, std::move(params), gpu);
    s.light_samples = light_samples_;
    return s;
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
    if (!property.empty()) RecordProperty("mean_abs_dv_" + property, dv_text(d));
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
