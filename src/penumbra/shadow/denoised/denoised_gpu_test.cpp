// `rt-denoised` on the GPU against its CPU version: the same traced fans (the reference's light
// samples) and the same filter, so the same pictures (mean |dV| at most 2e-3, issue 30) on the
// bunny and the alpha-masked foliage at 1 and 4 samples (the spatial and the per-pixel variance),
// with several camera rays a pixel (one image per ray index), every parameter, a crop, a moved
// camera, the statistics and the memory estimate. Small renders: lavapipe is slow.
#include <gtest/gtest.h>

#include <cmath>

#include <string>
#include <vector>

#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/testing/gpu_method_runs.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using gpu::testing::GpuTest;
using penumbra::testing::DevicePair;
using penumbra::testing::device_settings;
using penumbra::testing::render_on_both;
using penumbra::testing::shipped_scene;

class DenoisedGpu : public GpuTest {};

TEST_F(DenoisedGpu, BunnyAndFoliageGiveTheCpuPictures) {
  for (const char* name : {"bunny.json", "foliage.json"}) {
    const Scene scene = shipped_scene(name, 64);
    for (const char* samples : {"samples=1", "samples=4"}) {
      const DevicePair d = render_on_both(scene, "rt-denoised", {samples});
      EXPECT_GT(d.cpu_shadow, 10) << "no shadow to compare";
      EXPECT_LE(d.mean_abs_dv, 2e-3) << name << " " << samples;
      RecordProperty(std::string(name) + " " + samples, penumbra::testing::dv_text(d.mean_abs_dv));
      EXPECT_EQ(d.gpu.stats.rays_traced, d.cpu.stats.rays_traced) << name << " " << samples;
    }
    // Unfiltered, the traced estimates alone: the CPU's to float rounding, V (the area fraction)
    // and the colour (E: the irradiance ratio times the closed-form unshadowed irradiance).
    const DevicePair raw = render_on_both(scene, "rt-denoised", {"iterations=0"});
    EXPECT_LE(raw.mean_abs_dv, 1e-5) << name;
    double diff = 0, sum = 0;
    for (size_t i = 0; i < raw.cpu.color.data().size(); ++i) {
      diff += std::abs(raw.cpu.color.data()[i] - raw.gpu.color.data()[i]);
      sum += std::abs(raw.cpu.color.data()[i]);
    }
    EXPECT_GT(sum, 0) << name;
    EXPECT_LE(diff, 1e-4 * sum) << name << ": the colours differ";
  }
}

TEST_F(DenoisedGpu, EveryParameterAndSeveralRaysAPixelWorkAsOnTheCpu) {
  Scene scene = shipped_scene("bunny.json", 40);
  for (const std::vector<std::string>& p : std::vector<std::vector<std::string>>{
           {"samples=2", "iterations=3", "sigma_z=4", "sigma_n=32", "sigma_l=8"},
           {"samples=8", "iterations=7", "sigma_z=0.5", "sigma_n=0", "sigma_l=1"}})
    EXPECT_LE(render_on_both(scene, "rt-denoised", p).mean_abs_dv, 2e-3) << p[0];
  scene.camera.samples_per_pixel = 3;  // three images, one per camera-ray index
  EXPECT_LE(render_on_both(scene, "rt-denoised", {"samples=3"}).mean_abs_dv, 2e-3);
}

TEST_F(DenoisedGpu, CropsAMovedCameraStagesAndMemory) {
  const Scene scene = shipped_scene("bunny.json", 48);
  const PixelWindow crop{4, 6, 36, 30};
  RenderSettings cpu = device_settings("rt-denoised", {}, false);
  cpu.crop = crop;
  Renderer r(scene, device_settings("rt-denoised", {}, true));
  r.set_crop(crop);
  const RenderResult a = r.render(), b = render_scene(scene, cpu);
  EXPECT_EQ(a.visibility.width(), 32);
  EXPECT_LE(penumbra::testing::mean_abs_dv(a.visibility, b.visibility), 2e-3);
  for (const char* stage : {"trace", "filter"}) EXPECT_TRUE(a.gpu_ms.contains(stage)) << a.gpu_ms.dump();
  EXPECT_EQ(a.stats.extra.at("light_samples"), 4);
  // The whole frame after the crop: the planes, sized for the crop, are too small and grow.
  r.set_crop(PixelWindow{});
  const RenderResult whole = r.render();
  EXPECT_GT(whole.stats.memory_bytes, a.stats.memory_bytes);
  EXPECT_LE(penumbra::testing::mean_abs_dv(render_scene(scene, device_settings("rt-denoised", {}, false)).visibility,
                                           whole.visibility),
            2e-3);
  // Then a moved camera: the CPU's picture.
  const Camera cam = penumbra::testing::moved_camera(scene.camera, 0.2f);
  r.set_camera(cam);
  const RenderResult moved = r.render();
  const RenderResult want = penumbra::testing::cpu_render_with_camera(scene, cam, "rt-denoised", {});
  EXPECT_LE(penumbra::testing::mean_abs_dv(want.visibility, moved.visibility), 2e-3);
  const MemoryEstimate e = penumbra::testing::gpu_memory_estimate("rt-denoised", scene, {}, 48 * 48);
  EXPECT_GT(moved.stats.memory_bytes, 0u);
  EXPECT_LE(moved.stats.memory_bytes, e.bytes);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
