// The *_shared.h functions on both devices (docs/gpu.md, "One source of truth"): the generator bit
// for bit, the light samplers and the closed-form irradiance to float rounding (the GPU's sin,
// cos and sqrt are not libm's), through the test kernels gpu/kernels/test_*.comp.
#include <gtest/gtest.h>

#include <cmath>

#include "penumbra/core/rng.h"
#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/commands.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/scene/light.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra::gpu {
namespace {
namespace PENUMBRA_UNITY_ID {

class SharedFunctions : public testing::GpuTest {};

TEST_F(SharedFunctions, TheGeneratorDrawsTheCpusNumbersBitForBit) {
  constexpr uint32_t kStreams = 300, kDraws = 17;  // more than one group, not a multiple of it
  std::vector<uint64_t> keys;
  Rng pick(12345);
  for (uint32_t i = 0; i < kStreams; ++i)
    for (int k = 0; k < 4; ++k) keys.push_back(pick.next_u64() >> (i % 3 == 0 ? 40 : 0));
  Buffer key_buf = make_buffer<uint64_t>(device(), keys, "keys");
  Buffer u64_buf(device(), kStreams * kDraws * 8, "u64 draws");
  Buffer float_buf(device(), kStreams * kDraws * 4, "float draws");
  struct Push {
    uint64_t keys, out_u64, out_float;
    uint32_t streams, draws;
  } push{key_buf.address(), u64_buf.address(), float_buf.address(), kStreams, kDraws};
  CommandList cl(device());
  cl.stage("rng");
  cl.dispatch("test_rng", kStreams, push);
  const StageTimes t = cl.submit();
  ASSERT_EQ(t.ms.size(), 1u);
  EXPECT_EQ(t.ms[0].first, "rng");
  const std::vector<uint64_t> u = u64_buf.download_vector<uint64_t>(kStreams * kDraws);
  const std::vector<float> f = float_buf.download_vector<float>(kStreams * kDraws);
  for (uint32_t i = 0; i < kStreams; ++i) {
    Rng a(keys[4 * i], keys[4 * i + 1], keys[4 * i + 2], keys[4 * i + 3]), b = a;
    for (uint32_t k = 0; k < kDraws; ++k) {
      ASSERT_EQ(u[i * kDraws + k], a.next_u64()) << "stream " << i << " draw " << k;
      ASSERT_EQ(f[i * kDraws + k], b.next_float()) << "stream " << i << " draw " << k;
    }
  }
}

// Points around a light (some behind it, some near it) with normals, and u samples.
struct Probe {
  std::vector<Vec3f> points;  // p, n per point
  std::vector<Vec2f> u;       // kDraws per point
};
constexpr uint32_t kPoints = 200, kDraws = 8;

Probe probe_points(const AreaLight& light, uint64_t seed) {
  Probe p;
  Rng rng(seed);
  for (uint32_t i = 0; i < kPoints; ++i) {
    const Vec3f q = light.center + Vec3f(rng.next_float() * 6 - 3, -rng.next_float() * 3 + (i % 10 == 0 ? 1.0f : -0.2f),
                                         rng.next_float() * 6 - 3);
    const Vec3f n = normalize(Vec3f(rng.next_float() - 0.5f, 1.0f, rng.next_float() - 0.5f));
    p.points.push_back(q);
    p.points.push_back(i % 7 == 0 ? -n : n);
    for (uint32_t k = 0; k < kDraws; ++k) p.u.push_back(rng.next_2d());
  }
  return p;
}

void expect_light_functions_agree(Device& device, const AreaLight& light) {
  const Probe probe = probe_points(light, static_cast<uint64_t>(light.shape) + 1);
  const shader::LightGeometry geometry = light.geometry();
  Buffer light_buf(device, sizeof(geometry), "the light");
  light_buf.upload(&geometry, sizeof(geometry));
  Buffer points = make_buffer<Vec3f>(device, probe.points, "points");
  Buffer us = make_buffer<Vec2f>(device, probe.u, "u");
  Buffer samples(device, kPoints * kDraws * 7 * 4, "samples");
  Buffer irradiance(device, kPoints * 2 * 4, "irradiance");
  Buffer circle(device, 512 * 4, "the unit circle");
  circle.upload(unit_circle_table(), 512 * 4);
  struct Push {
    uint64_t light, points, u, samples, irradiance, circle;
    uint32_t count, draws;
  } push{light_buf.address(), points.address(), us.address(), samples.address(),
         irradiance.address(), circle.address(), kPoints, kDraws};
  CommandList cl(device);
  cl.dispatch("test_light_sampling", kPoints, push);
  cl.submit();
  const std::vector<float> s = samples.download_vector<float>(kPoints * kDraws * 7);
  const std::vector<float> e = irradiance.download_vector<float>(kPoints * 2);
  int sampled = 0;
  for (uint32_t i = 0; i < kPoints; ++i) {
    const Vec3f p = probe.points[2 * i], n = probe.points[2 * i + 1];
    const LightPointSampler sampler(light, p);
    const float want_e = light.unshadowed_irradiance_scalar(p, n);
    EXPECT_NEAR(e[2 * i + 1], want_e, 2e-4f * std::max(1.0f, std::abs(want_e))) << to_string(light.shape) << " point " << i;
    if (!sampler.valid()) {
      EXPECT_EQ(e[2 * i], 0.0f) << "the GPU's sampler has a mode where the CPU's has none";
      continue;
    }
    for (uint32_t k = 0; k < kDraws; ++k) {
      const float* g = &s[7 * (i * kDraws + k)];
      AreaLight::DirectionSample ds;
      const bool ok = sampler.sample(probe.u[i * kDraws + k], &ds);
      ASSERT_EQ(g[6] != 0.0f, ok) << to_string(light.shape) << " point " << i << " draw " << k;
      if (!ok) continue;
      ++sampled;
      // The light point itself (direction times distance) within 2e-4 of the distance, the
      // densities within 1e-3 (the spherical rectangle's inversion and grazing points, which
      // divide by cos_l, amplify ulp-sized differences).
      const Vec3f got = Vec3f(g[0], g[1], g[2]) * g[3], want = ds.dir * ds.dist;
      EXPECT_LE(length(got - want), 2e-4f * std::max(1.0f, ds.dist)) << to_string(light.shape) << " point " << i;
      EXPECT_NEAR(g[4], ds.pdf, 1e-3f * ds.pdf) << to_string(light.shape);
      EXPECT_NEAR(g[5], ds.area_weight, 1e-3f * std::max(1.0f, ds.area_weight)) << to_string(light.shape);
    }
  }
  EXPECT_GT(sampled, static_cast<int>(kPoints * kDraws / 2)) << to_string(light.shape);
}

TEST_F(SharedFunctions, EveryLightShapesSamplesAndIrradianceAgreeWithTheCpus) {
  for (const AreaLight& light : penumbra::testing::every_light_shape({0.2f, 2.0f, 0.1f}))
    expect_light_functions_agree(device(), light);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::gpu
