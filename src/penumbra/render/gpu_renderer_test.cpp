// The frame on the GPU against the same frame on the CPU (issue 28's tests): the camera pass,
// `reference` (the same light samples: ray for ray, and the pictures), `hard`, progressive
// frames, crops, several lights, moving objects, and the one-line errors.
#include "penumbra/render/gpu_renderer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>

#include "penumbra/core/error.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/gpu/ray_queries.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/shadow_rays.h"
#include "penumbra/testing/gpu_method_runs.h"
#include "penumbra/testing/method_runs.h"
#include "penumbra/testing/test_scenes.h"
#include "penumbra/trace/ray_shared.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using gpu::testing::GpuTest;

Scene suite_scene(const std::string& name, int resolution) {
  RunSetup setup = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name + ".json");
  setup.apply("resolution", std::to_string(resolution));
  return setup.load();
}

RenderResult render_on(const Scene& scene, RenderSettings settings, bool gpu) {
  settings.device = gpu::DeviceChoice::parse(gpu ? "gpu" : "cpu");
  return Renderer(scene, settings).render();
}

double mean_abs_diff(const Image& a, const Image& b) {
  EXPECT_EQ(a.data().size(), b.data().size());
  double sum = 0;
  for (size_t i = 0; i < a.data().size(); ++i) sum += std::abs(a.data()[i] - b.data()[i]);
  return a.data().empty() ? 0 : sum / static_cast<double>(a.data().size());
}

// V and colour of one method on both devices.
struct Pair {
  double v = 0, color = 0;
};
Pair compare_devices(const Scene& scene, RenderSettings settings) {
  const RenderResult cpu = render_on(scene, settings, false);
  const RenderResult gpu = render_on(scene, settings, true);
  EXPECT_NE(gpu.device, "cpu");
  EXPECT_TRUE(gpu.gpu_ms.is_object());
  // Colour relative to the image's mean (radiance has no fixed scale).
  double mean = 0;
  for (float c : cpu.color.data()) mean += c;
  mean = std::max(1e-9, mean / std::max<size_t>(1, cpu.color.data().size()));
  return {mean_abs_diff(cpu.visibility, gpu.visibility), mean_abs_diff(cpu.color, gpu.color) / mean};
}

class GpuFrame : public GpuTest {};

TEST_F(GpuFrame, TheCameraPassHitsTheCpusTrianglesAtTheCpusPoints) {
  for (const char* name : {"bunny", "foliage", "furball"}) {
    for (int spp : {1, 3}) {
      Scene scene = suite_scene(name, 48);
      scene.camera.samples_per_pixel = spp;
      RenderSettings settings;
      settings.method = "hard";
      settings.seed = 5;
      settings.device = gpu::DeviceChoice::parse("gpu");
      settings.crop = PixelWindow{3, 5, 45, 40};
      Renderer r(scene, settings);
      r.render();
      const ViewSamples got = r.gpu()->download_view_samples();
      const RayTracer tracer(scene);
      const ViewSamples want = camera_pass(scene, tracer, settings.seed, settings.crop);
      const float size = length(scene.bounds().diagonal());
      // Both list the hits in slot order; match them by camera ray.
      std::map<uint64_t, const ViewSample*> by_ray;
      for (const ViewSample& s : got.samples) by_ray[sample_key(s)] = &s;
      size_t same = 0;
      for (const ViewSample& w : want.samples) {
        auto it = by_ray.find(sample_key(w));
        if (it == by_ray.end()) continue;
        const ViewSample& g = *it->second;
        if (g.object != w.object || g.prim != w.prim) continue;
        ++same;
        EXPECT_LE(length(g.p - w.p), 1e-4f * size) << name;
        EXPECT_NEAR(dot(g.ng, w.ng), 1.0f, 1e-4f) << name;
        EXPECT_NEAR(dot(g.ns, w.ns), 1.0f, 1e-3f) << name;
        // Textured albedo: bilinear lookups at barycentrics a few ulps apart.
        EXPECT_LE(length(g.albedo - w.albedo), 2e-3f) << name;
      }
      std::printf("%s, %d camera rays a pixel: %zu of %zu hits on the same triangle\n", name, spp, same, want.size());
      EXPECT_GE(static_cast<double>(same), 0.999 * want.size()) << name << " spp " << spp;
      EXPECT_NEAR(static_cast<double>(got.size()), static_cast<double>(want.size()), 0.001 * want.size() + 1) << name;
    }
  }
}

// The reference's shadow rays for the CPU's view samples, traced by Embree and by the GPU.
void expect_reference_rays_agree(const Scene& scene, int spp) {
  const RayTracer tracer(scene);
  const ViewSamples vs = camera_pass(scene, tracer, 0);
  std::vector<ShadowRay> rays;
  const StratifiedGrid grid(spp);
  LightFanDraw draw(spp);
  const std::vector<AreaLight> lights = expand_textured_lights(scene.lights);
  for (size_t l = 0; l < lights.size(); ++l) {
    ShadowContext ctx;
    ctx.scene = &scene;
    ctx.light = &lights[l];
    ctx.light_index = static_cast<int>(l);
    for (size_t k = 0; k < vs.size(); k += 3) {
      const ViewSample& s = vs.samples[k];
      const int m = draw_light_fan(ctx, s, spp, grid, LightSampling::SolidAngle, draw);
      const float eps = shader::ray_offset_epsilon(s.p);
      const Vec3f n = length(s.ng) > 0 ? normalize(s.ng) : Vec3f(0.0f);
      for (int i = 0; i < m; ++i) {
        ShadowRay r;
        shader::fan_segment(s.p, n, eps, {draw.batch.x[i], draw.batch.y[i], draw.batch.z[i]}, r.org, r.dir);
        r.tnear = 0;
        r.tfar = shader::kFanTfar;
        rays.push_back(r);
      }
    }
  }
  std::vector<float> want(rays.size());
  tracer.transmittance(rays, want);
  const gpu::GpuScene gpu_scene(gpu::Device::get(-1), scene);
  const std::vector<float> got = gpu::trace_transmittance(gpu_scene, rays);
  size_t same = 0;
  double diff = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    same += std::abs(got[i] - want[i]) <= 1e-3f;
    diff += std::abs(got[i] - want[i]);
  }
  std::printf("%s: %zu of %zu shadow rays agree (%.5f), mean |dT| %.2e\n", scene.source.string().c_str(), same,
              rays.size(), static_cast<double>(same) / rays.size(), diff / rays.size());
  EXPECT_GE(static_cast<double>(same), 0.999 * rays.size())
      << scene.source.string() << ": " << same << " of " << rays.size() << " shadow rays agree";
}

void expect_reference_matches(const Scene& scene, int spp) {
  expect_reference_rays_agree(scene, spp);
  RenderSettings settings;
  settings.method = "reference";
  settings.light_samples = spp;
  settings.seed = 3;
  const Pair d = compare_devices(scene, settings);
  std::printf("%s: reference mean |dV| %.2e, colour %.2e of the mean\n", scene.source.string().c_str(), d.v, d.color);
  EXPECT_LE(d.v, 1e-3) << scene.source.string();
  EXPECT_LE(d.color, 1e-3) << scene.source.string();
}

TEST_F(GpuFrame, ReferenceTracesTheCpusRaysOnTheBunnyFoliageAndFurball) {
  for (const char* name : {"bunny", "foliage", "furball"}) expect_reference_matches(suite_scene(name, 40), 16);
}

// Thousands of light samples per view sample: past lavapipe's loop limit (65535 loop iterations
// a thread, gpu/loop_limit.h) the samples are split over dispatches, and the picture is still the
// CPU's with every ray traced.
TEST_F(GpuFrame, ReferenceWithManyLightSamplesTracesEveryRay) {
  const Scene scene = suite_scene("bunny", 16);
  RenderSettings settings;
  settings.method = "reference";
  settings.light_samples = 2048;
  settings.seed = 5;
  const RenderResult cpu = render_on(scene, settings, false);
  const RenderResult gpu = render_on(scene, settings, true);
  EXPECT_EQ(gpu.stats.rays_traced, cpu.stats.rays_traced);
  const double dv = mean_abs_diff(cpu.visibility, gpu.visibility);
  std::printf("reference at 2048 light samples: mean |dV| %.2e\n", dv);
  EXPECT_LE(dv, 1e-3);  // the reference tests' bound: a few rays of thousands graze an edge differently
}

TEST_F(GpuFrame, ReferenceMatchesForEveryLightShapeAndATexturedLight) {
  using penumbra::testing::box;
  using penumbra::testing::object;
  const std::vector<SceneObject> casters = {object(box({-0.6f, 0.3f, -0.4f}, {0.2f, 0.5f, 0.5f})),
                                            object(box({0.4f, 0, -0.9f}, {0.9f, 1.2f, -0.5f}))};
  for (const AreaLight& light : penumbra::testing::every_light_shape({0.2f, 2.0f, 0.1f})) {
    Scene s = penumbra::testing::ground_scene(casters, light, 40);
    s.source = std::string("light shape ") + to_string(light.shape);
    expect_reference_matches(s, 16);
  }
  expect_reference_matches(suite_scene("stained-glass", 32), 16);
}

TEST_F(GpuFrame, ReferenceWithAreaSamplingProgressiveFramesACropAndTwoLights) {
  Scene scene = suite_scene("bunny", 40);
  AreaLight second = scene.lights[0];
  second.center = second.center + Vec3f(1.0f, 0.3f, -0.5f);
  second.radiance = Vec3f(0.3f, 0.6f, 0.2f);
  scene.lights.push_back(second);
  scene.finalize();
  RenderSettings settings;
  settings.method = "reference";
  settings.light_samples = 8;
  settings.params = {"sampling=area"};
  settings.frames = 2;
  settings.first_frame = 1;
  settings.crop = PixelWindow{4, 6, 36, 30};
  const Pair d = compare_devices(scene, settings);
  EXPECT_LE(d.v, 1e-3);
  EXPECT_LE(d.color, 1e-3);
}

TEST_F(GpuFrame, HardShadowsMatch) {
  for (const char* name : {"bunny", "foliage", "furball"}) {
    RenderSettings settings;
    settings.method = "hard";
    const Pair d = compare_devices(suite_scene(name, 48), settings);
    EXPECT_LE(d.v, 1e-3) << name;
    EXPECT_LE(d.color, 1e-3) << name;
  }
}

// Kernel profiling (PENUMBRA_GPU_PROFILE=1; issue 31): the frame's time kernel by kernel, the
// same picture, the same stages, and kernels that account for the stages' time.
TEST_F(GpuFrame, KernelProfilingSplitsTheStagesByKernel) {
  const Scene scene = suite_scene("bunny", 48);
  RenderSettings settings;
  settings.method = "shadow-map";
  const RenderResult plain = render_on(scene, settings, true);
  EXPECT_TRUE(plain.gpu_kernels.is_null());
  ASSERT_EQ(setenv("PENUMBRA_GPU_PROFILE", "1", 1), 0);
  const RenderResult profiled = render_on(scene, settings, true);
  unsetenv("PENUMBRA_GPU_PROFILE");
  ASSERT_TRUE(profiled.gpu_kernels.is_object());
  EXPECT_EQ(mean_abs_diff(plain.visibility, profiled.visibility), 0.0);
  // The same stages (their times differ by the timestamps' cost and the run).
  for (auto it = plain.gpu_ms.begin(); it != plain.gpu_ms.end(); ++it)
    EXPECT_TRUE(profiled.gpu_ms.contains(it.key())) << it.key();
  EXPECT_EQ(plain.gpu_ms.size(), profiled.gpu_ms.size());
  // The shadow map's rasterizer and lookup, the frame's camera pass, each dispatched.
  for (const char* k : {"camera_pass", "raster_setup", "raster_fill", "raster_resolve", "shadow_map_lookup", "fill"}) {
    ASSERT_TRUE(profiled.gpu_kernels.contains(k)) << k << " in " << profiled.gpu_kernels.dump();
    EXPECT_GE(profiled.gpu_kernels[k]["dispatches"].get<uint64_t>(), 1u) << k;
    EXPECT_GE(profiled.gpu_kernels[k]["ms"].get<double>(), 0.0) << k;
  }
  // Every interval a command opens lies inside a stage: the kernels' sum is at most the frame's.
  double sum = 0;
  for (auto it = profiled.gpu_kernels.begin(); it != profiled.gpu_kernels.end(); ++it)
    sum += it.value()["ms"].get<double>();
  EXPECT_GT(sum, 0.0);
  EXPECT_LE(sum, profiled.gpu_ms["total"].get<double>() * (1 + 1e-9));
  EXPECT_GE(sum, 0.5 * profiled.gpu_ms["total"].get<double>());
}

TEST_F(GpuFrame, MovingObjectsOnTheGpuEqualFreshRenders) {
  Scene scene = suite_scene("bunny", 40);
  RenderSettings settings;
  settings.method = "reference";
  settings.light_samples = 8;
  settings.device = gpu::DeviceChoice::parse("gpu");
  settings.movable_objects = {0};
  Renderer r(scene, settings);
  r.render();
  std::vector<SceneObject> objects = scene.objects;
  objects[0].unshare();
  objects[0].mesh.transform(Mat4::translate({0.2f, 0.05f, -0.1f}));
  const uint32_t moved[] = {0};
  r.set_objects(objects, moved);
  const RenderResult after = r.render();
  EXPECT_EQ(r.refits(), 1);
  Scene fresh_scene = scene;
  fresh_scene.objects = objects;
  RenderSettings fresh = settings;
  fresh.movable_objects.clear();
  const RenderResult want = Renderer(fresh_scene, fresh).render();
  EXPECT_LE(mean_abs_diff(after.visibility, want.visibility), 1e-5);
}

// Every registered method has a GPU version (issues 29 and 30; `penumbra methods` lists "cpu, gpu"
// for each). A method added without one is refused in one line on the GPU (the command line's,
// viewer's and compare's tests check that message while such a method exists).
TEST_F(GpuFrame, EveryMethodRunsOnBothDevices) {
  for (const MethodInfo* m : MethodRegistry::all()) {
    EXPECT_NE(find_gpu_method(m->name), nullptr) << m->name << " has no GPU version";
    EXPECT_EQ(method_devices(m->name), "cpu, gpu") << m->name;
  }
  EXPECT_EQ(testing::cpu_only_method(), "");
}

// scene_units_test.cpp's two properties on the GPU: every method draws the same V for the scene
// 100 times smaller and 10^5 times larger, and V = 0 where the light faces away.
TEST_F(GpuFrame, EveryMethodsVIsTheSameInAnyUnitAndZeroWhereTheLightFacesAway) {
  for (const MethodInfo* m : MethodRegistry::all()) {
    const RenderSettings settings = testing::device_settings(m->name, {}, true, 3, 16);
    const RenderResult unit = render_on(testing::contact_scene_at_scale(1.0f), settings, true);
    for (float scale : {1e-2f, 1e5f}) {
      const RenderResult scaled = render_on(testing::contact_scene_at_scale(scale), settings, true);
      EXPECT_LE(mean_abs_diff(scaled.visibility, unit.visibility), testing::kSceneUnitsTolerance)
          << m->name << " at scale " << scale;
    }
    const RenderResult away = render_on(testing::facing_away_ground_only(), settings, true);
    for (float v : away.visibility.data()) ASSERT_EQ(v, 0.0f) << m->name;
  }
}

// scene_units_test.cpp's scene far from the origin (2 x 10^4 units out, where a float coordinate
// is exact to 0.002): every method's GPU version draws its CPU version's V there (the ray offset,
// the eye-relative texel projection and the biases are the devices' shared functions).
TEST_F(GpuFrame, FarFromTheOriginEveryMethodDrawsTheCpusV) {
  const Scene far = testing::contact_scene_at_scale(1.0f, 40, Vec3f(2e4f, 50.0f, -1.5e4f));
  for (const MethodInfo* m : MethodRegistry::all()) {
    const RenderSettings settings = testing::device_settings(m->name, {}, true, 3, 16);
    const RenderResult gpu = render_on(far, settings, true), cpu = render_on(far, settings, false);
    const double dv = mean_abs_diff(gpu.visibility, cpu.visibility);
    std::printf("%-20s GPU against CPU at offset 2e4: %.6f\n", m->name.c_str(), dv);
    EXPECT_LE(dv, 2e-3) << m->name;
  }
}

// scene_units_test.cpp's ceiling flush with the light: the methods that leave out what lies on or
// behind the light's plane do so on the GPU as on the CPU (afsm's caster kernel, the multilayer
// maps' near plane from the shared plan, single-sample's occluders built once for both devices).
TEST_F(GpuFrame, ACeilingFlushWithTheLightBlocksNothingAsOnTheCpu) {
  const Scene scene = testing::with_a_ceiling_at_the_light(testing::contact_scene_at_scale(1.0f, 32), 0.0f, 1.0f);
  for (const char* method : {"afsm", "mlsm", "mtsm", "single-sample"}) {
    const RenderSettings settings = testing::device_settings(method, {}, true, 3, 16);
    const RenderResult gpu = render_on(scene, settings, true), cpu = render_on(scene, settings, false);
    const double dv = mean_abs_diff(gpu.visibility, cpu.visibility);
    std::printf("%-20s GPU against CPU with the ceiling: %.6f\n", method, dv);
    EXPECT_LE(dv, 2e-3) << method;
  }
}

// scene_units_test.cpp's bulb in a room: the faces of the split sphere (split_sphere_lights) draw
// their own view samples on the GPU (face_samples.comp) as on the CPU, each method's V as the
// CPU's.
TEST_F(GpuFrame, ABulbInARoomIsDrawnFaceByFaceAsOnTheCpu) {
  const Scene scene = testing::bulb_in_a_room_scene(24);
  for (const char* method : {"afsm", "shadow-map", "vsm", "occlusion-textures"}) {
    const RenderSettings settings = testing::device_settings(method, {}, true, 3, 16);
    const RenderResult gpu = render_on(scene, settings, true), cpu = render_on(scene, settings, false);
    const double dv = mean_abs_diff(gpu.visibility, cpu.visibility);
    std::printf("%-20s GPU against CPU, a bulb in a room: %.6f\n", method, dv);
    EXPECT_LE(dv, 2e-3) << method;
    EXPECT_LE(mean_abs_diff(gpu.color, cpu.color), 2e-3) << method;
  }
}

// Objects moving around a bulb split it again on the GPU as on the CPU
// (Renderer.MovingObjectsSplitsASphereLightByTheNewBounds): the frame after set_objects is a
// fresh GPU render of the moved scene.
TEST_F(GpuFrame, MovingObjectsSplitASphereLightAgainAsAFreshRender) {
  const Scene room = testing::bulb_in_a_room_scene(24), below = testing::bulb_room_lowered_scene(24);
  RenderSettings settings = testing::device_settings("shadow-map", {}, true, 3, 16);
  settings.movable_objects = {1, 2, 3, 4, 5, 6};
  Renderer r(below, settings);
  r.render();
  r.set_objects(room.objects, settings.movable_objects);
  EXPECT_GT(r.scene().lights.size(), 1u);
  const RenderResult after = r.render();
  settings.movable_objects.clear();
  EXPECT_LE(mean_abs_diff(after.visibility, render_on(room, settings, true).visibility), 1e-4);
}

// baselines_test.cpp's street: the fitted maps hold the receivers beyond max_fov a caster can
// shadow on the GPU as on the CPU (the reach is host code both devices' fits call).
TEST_F(GpuFrame, ReceiversBeyondMaxFovThatACasterCanShadowAreInTheMapAsOnTheCpu) {
  const Scene street = testing::street_beyond_the_cap_scene(32);
  for (const char* method : {"shadow-map", "pcss", "afsm", "afsm-hard"}) {
    const RenderSettings settings = testing::device_settings(method, {}, true, 3, 16);
    const RenderResult gpu = render_on(street, settings, true), cpu = render_on(street, settings, false);
    EXPECT_EQ(gpu.stats.extra.value("receivers_outside_map", uint64_t{0}), 0u) << method;
    EXPECT_LE(mean_abs_diff(gpu.visibility, cpu.visibility), 2e-3) << method;
  }
}

TEST_F(GpuFrame, ARenderOverTheGpusMemoryIsRefusedUpFront) {
  RenderSettings settings;
  settings.method = "reference";
  settings.device = gpu::DeviceChoice::parse("gpu");
  settings.memory_limit = 64 << 10;  // 64 KiB
  const uint64_t before = device().allocated_bytes();
  try {
    Renderer(suite_scene("bunny", 64), settings);
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("GPU memory"), std::string::npos) << m;
    EXPECT_NE(m.find("--memory-limit"), std::string::npos) << m;
  }
  EXPECT_EQ(device().allocated_bytes(), before) << "nothing allocated before the check";
  // The device's own capacity applies without a limit.
  settings.memory_limit = 0;
  Scene big = suite_scene("bunny", 16);
  big.camera.width = big.camera.height = 16384;
  big.camera.samples_per_pixel = 64;
  EXPECT_THROW(Renderer(big, settings), Error);
}

TEST_F(GpuFrame, TheUpFrontEstimateCoversWhatARenderHolds) {
  gpu::unit_circle_buffer(device());  // held once per device for the whole process
  // Every method with a GPU version, with maps smaller than the defaults (lavapipe is slow).
  const std::map<std::string, std::vector<std::string>> smaller = {
      {"vsm", {"resolution=256"}}, {"evsm", {"resolution=256", "prefilter=mipmap"}}, {"msm", {"resolution=256"}},
      {"occlusion-textures", {"resolution=256"}}, {"lam", {"resolution=256"}}, {"multi-view-sm", {"resolution=256"}},
      {"mlsm", {"resolution=256"}}, {"mtsm", {"resolution=256"}}, {"coherent-rt", {"resolution=128"}},
      {"afsm", {"resolution=128"}}, {"afsm-hard", {"resolution=128"}}};
  std::vector<std::pair<std::string, std::vector<std::string>>> methods;
  for (const MethodInfo* m : MethodRegistry::all()) {
    if (!find_gpu_method(m->name)) continue;
    const auto it = smaller.find(m->name);
    methods.emplace_back(m->name, it == smaller.end() ? std::vector<std::string>{} : it->second);
  }
  EXPECT_GE(methods.size(), 17u);
  for (const auto& spec : methods) {
    const std::string& method = spec.first;
    for (const char* name : {"bunny", "foliage"}) {
      Scene scene = suite_scene(name, 48);
      scene.camera.samples_per_pixel = 2;
      RenderSettings settings;
      settings.method = method;
      settings.params = spec.second;
      settings.light_samples = 8;
      settings.frames = 2;
      settings.device = gpu::DeviceChoice::parse("gpu");
      const uint64_t before = device().allocated_bytes();
      const GpuMemoryEstimate estimate = estimate_gpu_render_memory(scene, settings);
      {
        Renderer r(scene, settings);
        const RenderResult result = r.render();
        const uint64_t held = device().allocated_bytes() - before;
        EXPECT_LE(held, estimate.total()) << method << " on " << name << ": holds " << held << " bytes, estimated "
                                          << estimate.total();
        // A method may free its build storage before the render returns (lam's LDI build): the
        // peak it reports counts too.
        const uint64_t peak = std::max(held, result.stats.memory_bytes);
        EXPECT_LE(peak, estimate.total()) << method << " on " << name << ": peaks at " << peak << " bytes";
        EXPECT_GT(peak, estimate.total() / 20) << method << " on " << name << ": the estimate is far off";
      }
      EXPECT_EQ(device().allocated_bytes(), before) << method << ": a render's buffers outlive it";
    }
  }
}

TEST_F(GpuFrame, AFailedVulkanCallIsAnErrorAndTheDeviceStaysUsable) {
  RenderSettings settings;
  settings.method = "hard";
  settings.device = gpu::DeviceChoice::parse("gpu");
  const Scene scene = suite_scene("bunny", 16);
  gpu::testing::fail_next(gpu::testing::Failure::Allocation);
  EXPECT_THROW(Renderer(scene, settings), Error);
  Renderer r(scene, settings);
  gpu::testing::fail_next(gpu::testing::Failure::Submission);
  EXPECT_THROW(r.render(), Error);
  EXPECT_NO_THROW(r.render());
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
