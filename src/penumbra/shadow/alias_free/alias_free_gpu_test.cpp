// `afsm-hard` and `afsm` on the GPU (issue 29): sample-exact against GPU rays traced to their own
// light points (the light's centre; afsm's N fixed samples) from every view sample, the CPU
// version's picture, a list buffer too small for the scene (grown, never dropped) and the memory
// estimate. Small renders: lavapipe is slow.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "penumbra/core/rng.h"
#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/commands.h"
#include "penumbra/gpu/gpu_scene.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/gpu/ray_queries.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/alias_free/alias_free_gpu_testing.h"
#include "penumbra/shadow/alias_free/alias_free_shared.h"
#include "penumbra/shadow/alias_free/sample_masks.h"
#include "penumbra/testing/gpu_method_runs.h"
#include "penumbra/testing/method_runs.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using gpu::testing::GpuTest;

class AliasFreeGpu : public GpuTest {
 protected:
  // The GPU ray tracer's hard shadows to the light's centre from every view sample of `r`
  // (testing::embree_hard's rays, traced by gpu::trace_transmittance).
  std::vector<float> gpu_rays_to_centre(const testing::SceneRun& r) {
    const AreaLight& light = r.scene.lights[0];
    std::vector<ShadowRay> rays(r.vs.size());
    for (size_t k = 0; k < rays.size(); ++k) rays[k] = shadow_ray_to(r.vs.samples[k].p, r.vs.samples[k].ng, light.center);
    const gpu::GpuScene scene(device(), r.scene);
    std::vector<float> v = gpu::trace_transmittance(scene, rays);
    for (size_t k = 0; k < v.size(); ++k)
      if (!testing::in_front(light, r.vs.samples[k].p)) v[k] = 0;
    return v;
  }
  // afsm at N light samples: every view sample's V against the GPU rays to afsm's own N points
  // (the renderer's seed, light 0, frame 0), and the CPU version's picture.
  void expect_soft_exact(const std::string& name, int resolution, int n) {
    const testing::SceneRun r = testing::load_scene_at(name, resolution);
    RenderSettings gpu_settings = testing::device_settings("afsm", {"resolution=64"}, true);
    gpu_settings.light_samples = n;
    const RenderResult gpu = render_scene(r.scene, gpu_settings);
    const std::vector<float> v = testing::per_sample(r, gpu);
    const afsm::LightSamples pts = afsm::make_light_samples(r.scene.lights[0], n, gpu_settings.seed, 0, 0);
    const std::vector<float> rays = testing::gpu_rays_to_points(device(), r, pts.points);
    const testing::Agreement g = testing::agreement(v, rays);
    std::printf("GPU afsm N=%d vs GPU rays to the same points, %s: %.5f of %zu equal, max |dV| %.5f\n", n, name.c_str(),
                g.equal_fraction, v.size(), g.max_diff);
    // Where semi-transparent casters let part of the light through, the kernel's own rays to the
    // light samples they cover decide; the rays compared with are set up on the host
    // (shadow_ray_to), a rounding apart, and one of them may graze a hair strand the other misses
    // (the furball at 32², 16 samples: 1 view sample of 694, by 0.002).
    EXPECT_GE(g.equal_fraction, r.scene.semi_transparent() ? 0.995 : 0.999) << name << ", " << testing::worst_sample(r, v, rays);
    EXPECT_LE(g.max_diff, 1.0f / n + 1e-6f) << name << ", " << testing::worst_sample(r, v, rays);
    EXPECT_GT(std::count_if(v.begin(), v.end(), [](float x) { return x > 0.05f && x < 0.95f; }), 10) << "no penumbra";
    EXPECT_GT(gpu.stats.extra["sample_tests"].get<uint64_t>(), 0u);
    RenderSettings cpu_settings = testing::device_settings("afsm", {"resolution=64"}, false);
    cpu_settings.light_samples = n;
    const RenderResult cpu = render_scene(r.scene, cpu_settings);
    const double dv = testing::mean_abs_dv(cpu.visibility, gpu.visibility);
    std::printf("GPU afsm N=%d vs CPU, %s: mean |dV| %.2e\n", n, name.c_str(), dv);
    EXPECT_LE(dv, 2e-3) << name;
  }
  void expect_exact(const std::string& name, int resolution) {
    const testing::SceneRun r = testing::load_scene_at(name, resolution);
    const RenderResult gpu = render_scene(r.scene, testing::device_settings("afsm-hard", {"resolution=256"}, true));
    EXPECT_EQ(gpu.device, device().info().name);
    const std::vector<float> v = testing::per_sample(r, gpu);
    const std::vector<float> rays = gpu_rays_to_centre(r);
    const testing::Agreement g = testing::agreement(v, rays);
    std::printf("GPU afsm-hard vs GPU rays to the centre, %s: %.5f of %zu view samples equal\n", name.c_str(),
                g.equal_fraction, v.size());
    EXPECT_GE(g.equal_fraction, 0.999) << name << ", " << testing::worst_sample(r, v, rays);
    // Binary, except where only semi-transparent casters cover a sample (its ray decides).
    if (!r.scene.semi_transparent())
      for (float x : v) ASSERT_TRUE(x == 0.0f || x == 1.0f);
    else
      EXPECT_GT(std::count_if(v.begin(), v.end(), [](float x) { return x > 0.0f && x < 1.0f; }), 10) << name;
    EXPECT_GT(std::count(v.begin(), v.end(), 0.0f), 50) << name << ": no shadow";
    EXPECT_GT(std::count(v.begin(), v.end(), 1.0f), 50) << name << ": no light";
    EXPECT_GT(gpu.stats.extra["listed_samples"].get<uint64_t>(), 0u);
    EXPECT_GT(gpu.stats.texels_visited, 0u);
    EXPECT_GT(gpu.stats.extra["sample_tests"].get<uint64_t>(), 0u);
    // The CPU version's picture.
    const RenderResult cpu = render_scene(r.scene, testing::device_settings("afsm-hard", {"resolution=256"}, false));
    const double dv = testing::mean_abs_dv(cpu.visibility, gpu.visibility);
    std::printf("GPU afsm-hard vs CPU, %s: mean |dV| %.2e\n", name.c_str(), dv);
    EXPECT_LE(dv, 2e-3) << name;
  }
};

// The per-pair set-up of the GPU (test_afsm_pair_lines.comp) against the CPU's call of the same
// alias_free_shared.h function: the same pairs kept; the lines equal up to a few ulps (the GPU may
// fuse the cross products' multiply-adds), bit for bit on most.
TEST_F(AliasFreeGpu, PairLinesOnTheDeviceAreTheCpus) {
  const AreaLight light = testing::rect_light_down({0, 2, 0}, 1.5f, 1.5f);
  const afsm::LightSamples samples = afsm::make_light_samples(light, 64, 3, 0, 0);
  const Vec3f c = samples.center, ls = samples.s * samples.radius, lt = samples.t * samples.radius;
  struct PairIn {
    Vec3f p, v0, v1, v2;
    uint32_t closed;
  };
  struct PairOut {
    shader::AfsmPairLines lines;
    float kept;
  };
  static_assert(sizeof(PairIn) == 52 && sizeof(PairOut) == 52);
  Rng rng(5);
  std::vector<PairIn> in(4000);
  for (size_t i = 0; i < in.size(); ++i) {
    const Vec3f centre{rng.next_float() * 3 - 1.5f, 0.4f + rng.next_float() * 1.2f, rng.next_float() * 3 - 1.5f};
    auto jitter = [&] { return Vec3f(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f) * 0.3f; };
    in[i] = {{rng.next_float() * 4 - 2, rng.next_float() * 0.6f, rng.next_float() * 4 - 2}, centre + jitter(),
             centre + jitter(), centre + jitter(), static_cast<uint32_t>(i % 3 == 0)};
  }
  gpu::Buffer in_buf = gpu::make_buffer<PairIn>(device(), in, "pairs");
  gpu::Buffer out_buf(device(), in.size() * sizeof(PairOut), "pair lines");
  struct Push {
    uint64_t in_pairs, out_pairs;
    Vec3f c;
    uint32_t count;
    Vec3f ls;
    uint32_t pad0;
    Vec3f lt;
    uint32_t pad1;
  } push{in_buf.address(), out_buf.address(), c, static_cast<uint32_t>(in.size()), ls, 0, lt, 0};
  gpu::CommandList cl(device());
  cl.dispatch("test_afsm_pair_lines", in.size(), push);
  cl.submit();
  const std::vector<PairOut> got = out_buf.download_vector<PairOut>(in.size());
  size_t kept = 0, same = 0;
  for (size_t i = 0; i < in.size(); ++i) {
    const PairIn& r = in[i];
    const Vec3f normal = cross(r.v1 - r.v0, r.v2 - r.v0);
    const float len = length(normal);
    shader::AfsmPairLines want{};
    const bool keep = shader::afsm_pair_lines(r.p, r.v0, r.v1, r.v2, normal, shader::kAfsmFlat * shader::kAfsmFlat * len * len,
                                              r.closed != 0, c, ls, lt, want);
    ASSERT_EQ(got[i].kept, keep ? 1.0f : 0.0f) << "pair " << i;
    if (!keep) continue;
    ++kept;
    const float a[12] = {want.g0.x, want.g0.y, want.h0, want.g1.x, want.g1.y, want.h1,
                         want.g2.x, want.g2.y, want.h2, want.gb.x, want.gb.y, want.hb};
    const shader::AfsmPairLines& g = got[i].lines;
    const float b[12] = {g.g0.x, g.g0.y, g.h0, g.g1.x, g.g1.y, g.h1, g.g2.x, g.g2.y, g.h2, g.gb.x, g.gb.y, g.hb};
    bool equal = true;
    for (int k = 0; k < 12; ++k) {
      EXPECT_NEAR(b[k], a[k], 1e-5f * (1 + std::abs(a[k]))) << "pair " << i << " value " << k;
      equal = equal && a[k] == b[k];
    }
    same += equal;
  }
  std::printf("afsm_pair_lines: %zu of %zu kept pairs bit-equal on the GPU\n", same, kept);
  EXPECT_GT(kept, 1000u);
}

TEST_F(AliasFreeGpu, HardBunnyEqualsGpuRaysToTheCentre) { expect_exact("bunny", 64); }

TEST_F(AliasFreeGpu, HardAlphaMaskedFoliageEqualsGpuRaysToTheCentre) { expect_exact("foliage", 64); }

// The furball's hair is semi-transparent (opacity 0.3-0.9): where only hair covers a sample, its
// ray to the centre (afsm-hard) or to each light sample the hair covers (afsm) lets part through.
TEST_F(AliasFreeGpu, HardSemiTransparentFurballEqualsGpuRaysToTheCentre) { expect_exact("furball", 48); }
TEST_F(AliasFreeGpu, SoftSemiTransparentFurballEqualsGpuRaysToTheSameLightPoints) { expect_soft_exact("furball", 32, 16); }

// Receivers no light view capped at max_fov can hold (alias_free_test.cpp's ledge beside the
// light): their rays decide on the GPU too, the CPU's picture and the GPU rays to the same points.
TEST_F(AliasFreeGpu, ReceiversTheCappedViewCannotHoldAreTracedAsOnTheCpu) {
  const testing::SceneRun r = testing::build_scene_run(testing::ledge_beside_the_light_scene(32));
  const int n = 16;
  for (const char* method : {"afsm-hard", "afsm"}) {
    RenderSettings settings[2] = {testing::device_settings(method, {"resolution=64"}, false),
                                  testing::device_settings(method, {"resolution=64"}, true)};
    for (RenderSettings& s : settings) s.light_samples = n;
    const RenderResult cpu = render_scene(r.scene, settings[0]);
    const RenderResult gpu = render_scene(r.scene, settings[1]);
    const double dv = testing::mean_abs_dv(cpu.visibility, gpu.visibility);
    std::printf("GPU %s vs CPU, a ledge beside the light: mean |dV| %.2e\n", method, dv);
    EXPECT_LE(dv, 2e-3) << method;
    const std::vector<float> v = testing::per_sample(r, gpu);
    const std::vector<float> rays =
        std::string(method) == "afsm"
            ? testing::gpu_rays_to_points(device(), r,
                                          afsm::make_light_samples(r.scene.lights[0], n, settings[1].seed, 0, 0).points)
            : gpu_rays_to_centre(r);
    EXPECT_GE(testing::agreement(v, rays).equal_fraction, 0.999) << method << ", " << testing::worst_sample(r, v, rays);
  }
}

// 32² view samples, 16 light samples, 64² lists: a few seconds on lavapipe.
TEST_F(AliasFreeGpu, SoftBunnyEqualsGpuRaysToTheSameLightPoints) { expect_soft_exact("bunny", 32, 16); }

// The leaves are thin two-sided alpha-masked quads: samples lit partly from behind are listed
// once per side (the split of issue 33).
TEST_F(AliasFreeGpu, SoftAlphaMaskedFoliageEqualsGpuRaysToTheSameLightPoints) { expect_soft_exact("foliage", 32, 16); }

// §4.2's plane-mask table changes the work, not the bits: lut=false (every sample tested) and a
// coarse and the default table give the same picture.
TEST_F(AliasFreeGpu, SoftTableAndExactTestsGiveTheSamePicture) {
  const Scene scene = testing::shipped_scene("foliage.json", 24);
  std::vector<float> first;
  for (const char* lut : {"lut=false", "lut_resolution=8", "lut_resolution=128"}) {
    RenderSettings settings = testing::device_settings("afsm", {"resolution=64", lut}, true);
    settings.light_samples = 40;  // two mask words, the second partly used
    const RenderResult gpu = render_scene(scene, settings);
    if (first.empty()) first = gpu.visibility.data();
    EXPECT_EQ(gpu.visibility.data(), first) << lut;
  }
}

// The depth slabs (the CPU's split_by_depth: each slab's influence regions on its own far plane,
// clipped to the rows that hold its lists) change the work, not the bits: one slab, the default 8
// and 64 (most of them empty or one depth bin at 32² view samples) give the same picture, and 8
// test fewer (listed sample, caster) pairs than one.
TEST_F(AliasFreeGpu, SoftDepthSlabsChangeTheWorkNotThePicture) {
  const Scene scene = testing::shipped_scene("bunny.json", 32);
  std::vector<float> first;
  uint64_t tests[3] = {};
  int i = 0;
  for (const char* slabs : {"slabs=1", "slabs=8", "slabs=64"}) {
    RenderSettings settings = testing::device_settings("afsm", {"resolution=64", slabs}, true);
    settings.light_samples = 16;
    const RenderResult gpu = render_scene(scene, settings);
    if (first.empty()) first = gpu.visibility.data();
    EXPECT_EQ(gpu.visibility.data(), first) << slabs;
    tests[i++] = gpu.stats.extra["sample_tests"].get<uint64_t>();
    EXPECT_GT(gpu.stats.extra["cover_rows"].get<uint64_t>(), 0u) << slabs;
  }
  std::printf("afsm pair tests with 1, 8, 64 slabs: %llu, %llu, %llu\n", static_cast<unsigned long long>(tests[0]),
              static_cast<unsigned long long>(tests[1]), static_cast<unsigned long long>(tests[2]));
  EXPECT_LT(tests[1], tests[0]);
}

// A crop window (fewer view-sample slots than pixels) and two progressive frames (afsm: new light
// samples per frame; the instance's buffers reused by the second): the CPU's pictures.
TEST_F(AliasFreeGpu, CropAndProgressiveFramesGiveTheCpuPictures) {
  const Scene scene = testing::shipped_scene("foliage.json", 32);
  for (const char* method : {"afsm-hard", "afsm"}) {
    RenderSettings settings[2] = {testing::device_settings(method, {"resolution=64"}, false),
                                  testing::device_settings(method, {"resolution=64"}, true)};
    for (RenderSettings& s : settings) {
      s.light_samples = 8;
      s.frames = 2;
      s.crop = PixelWindow{3, 4, 29, 27};
    }
    const RenderResult cpu = render_scene(scene, settings[0]);
    const RenderResult gpu = render_scene(scene, settings[1]);
    EXPECT_EQ(gpu.visibility.width(), 26) << method;
    EXPECT_LE(testing::mean_abs_dv(cpu.visibility, gpu.visibility), 2e-3) << method;
  }
}

// A list buffer far too small for the scene's listed samples: the render grows it (after the
// counting pass) and gives the same picture, never a partial list.
TEST_F(AliasFreeGpu, HardListBufferTooSmallIsGrownNotDropped) {
  const Scene scene = testing::shipped_scene("bunny.json", 48);
  const RenderResult normal = render_scene(scene, testing::device_settings("afsm-hard", {"resolution=128"}, true));
  afsm::AfsmListCapacityForTesting small(16);
  const RenderResult grown = render_scene(scene, testing::device_settings("afsm-hard", {"resolution=128"}, true));
  EXPECT_GE(small.grows(), 1);
  EXPECT_GT(grown.stats.extra["listed_samples"].get<uint64_t>(), 16u);
  EXPECT_EQ(normal.visibility.data(), grown.visibility.data());
}

// afsm lists a split sample twice (foliage): its buffer too small is grown the same way.
TEST_F(AliasFreeGpu, SoftListBufferTooSmallIsGrownNotDropped) {
  const Scene scene = testing::shipped_scene("foliage.json", 24);
  RenderSettings settings = testing::device_settings("afsm", {"resolution=64"}, true);
  settings.light_samples = 8;
  const RenderResult normal = render_scene(scene, settings);
  afsm::AfsmListCapacityForTesting small(16);
  const RenderResult grown = render_scene(scene, settings);
  EXPECT_GE(small.grows(), 1);
  EXPECT_EQ(normal.visibility.data(), grown.visibility.data());
}

// The up-front estimate covers what a render holds on the device.
TEST_F(AliasFreeGpu, MemoryEstimatesCoverTheRender) {
  const Scene scene = testing::shipped_scene("foliage.json", 24);
  for (const char* method : {"afsm-hard", "afsm"}) {
    RenderSettings settings = testing::device_settings(method, {"resolution=64"}, true);
    settings.light_samples = 8;
    const RenderResult gpu = render_scene(scene, settings);
    const MemoryEstimate e = testing::gpu_memory_estimate(method, scene, {"resolution=64"}, gpu.view_sample_count);
    EXPECT_GT(gpu.stats.memory_bytes, 0u) << method;
    EXPECT_GE(e.bytes, gpu.stats.memory_bytes) << method;
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
