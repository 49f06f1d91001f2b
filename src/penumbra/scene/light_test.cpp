#include "penumbra/scene/light.h"

#include <gtest/gtest.h>

#include <cmath>

#include "penumbra/core/sampling.h"

namespace penumbra {
namespace {

// Configuration-factor form of the irradiance of a unit-radiance rectangle a x b parallel
// to the receiver at height c, with the receiver point under one corner (Howell's
// catalogue, factor B-3): E = pi * F with
// F = 1/(2 pi) [X/sqrt(1+X^2) atan(Y/sqrt(1+X^2)) + Y/sqrt(1+Y^2) atan(X/sqrt(1+Y^2))].
double corner_rect_irradiance(double a, double b, double c) {
  double X = a / c, Y = b / c;
  double F = (X / std::sqrt(1 + X * X) * std::atan(Y / std::sqrt(1 + X * X)) +
              Y / std::sqrt(1 + Y * Y) * std::atan(X / std::sqrt(1 + Y * Y))) / (2 * kPi);
  return kPi * F;
}

AreaLight rect(Vec3f c, float w, float h) {
  AreaLight l;
  l.shape = LightShape::Rect;
  l.center = c;
  l.frame = Frame::from_zx({0, -1, 0}, {1, 0, 0});
  l.size = {w, h};
  return l;
}

TEST(AreaLight, RectIrradianceMatchesConfigurationFactor) {
  // A 2 x 1 light at height 1.5 centred over the origin: four corner rectangles.
  AreaLight l = rect({0, 1.5f, 0}, 2, 1);
  double expected = 4 * corner_rect_irradiance(1.0, 0.5, 1.5);
  EXPECT_NEAR(l.unshadowed_irradiance_scalar({0, 0, 0}, {0, 1, 0}), expected, 1e-5 * expected);
  // Under a corner of the light: one corner rectangle of the full size.
  double corner = corner_rect_irradiance(2.0, 1.0, 1.5);
  EXPECT_NEAR(l.unshadowed_irradiance_scalar({1, 0, 0.5f}, {0, 1, 0}), corner, 1e-5 * corner);
}

TEST(AreaLight, RectIrradianceIsClippedToTheHorizon) {
  AreaLight l = rect({0, 1, 0}, 2, 2);
  // A point facing away from the light gets nothing; a vertical receiver under the
  // light's centre sees exactly half of it above its horizon.
  EXPECT_EQ(l.unshadowed_irradiance_scalar({0, 0, 0}, {0, -1, 0}), 0.0f);
  float vertical = l.unshadowed_irradiance_scalar({0, 0, 0}, {1, 0, 0});
  EXPECT_GT(vertical, 0.0f);
  // Numeric check of the vertical case by dense midpoint quadrature over the light area.
  double sum = 0;
  const int k = 800;
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      Vec3f q(-1 + 2 * (i + 0.5f) / k, 1, -1 + 2 * (j + 0.5f) / k);
      Vec3f d = q;  // from the origin
      float r2 = length_squared(d);
      Vec3f w = d / std::sqrt(r2);
      sum += std::max(0.0f, w.x) * w.y / r2 * (4.0 / (k * k));
    }
  EXPECT_NEAR(vertical, sum, 2e-3 * sum);
}

TEST(AreaLight, DiskOnAxisIrradiance) {
  AreaLight l;
  l.shape = LightShape::Disk;
  l.center = {0, 2, 0};
  l.frame = Frame::from_z({0, -1, 0});
  l.radius = 0.75f;
  double R2 = 0.75 * 0.75, h2 = 4.0;
  double expected = kPi * R2 / (R2 + h2);  // pi L R^2 / (R^2 + h^2)
  EXPECT_NEAR(l.unshadowed_irradiance_scalar({0, 0, 0}, {0, 1, 0}), expected, 1e-4 * expected);
}

TEST(AreaLight, SphereIrradianceAgreesWithConeQuadrature) {
  AreaLight l;
  l.shape = LightShape::Sphere;
  l.center = {0, 3, 0};
  l.radius = 1.0f;
  for (Vec3f n : {Vec3f(0, 1, 0), normalize(Vec3f(1, 1, 0)), normalize(Vec3f(1, 0.15f, 0))}) {
    // Independent estimate: stratified cone sampling with the cosine.
    Vec3f to_c = l.center;
    float d = length(to_c);
    float cos_max = std::sqrt(1 - 1.0f / (d * d));
    Frame f = Frame::from_z(to_c / d);
    double sum = 0;
    const int k = 256;
    for (int j = 0; j < k; ++j)
      for (int i = 0; i < k; ++i) sum += std::max(0.0f, dot(n, f.to_world(square_to_cone({(i + 0.5f) / k, (j + 0.5f) / k}, cos_max))));
    double expected = sum / (k * k) / cone_pdf(cos_max);
    EXPECT_NEAR(l.unshadowed_irradiance_scalar({0, 0, 0}, n), expected, 2e-3 * expected) << n.x;
  }
}

// Solid angle of a planar polygon seen from the origin (Van Oosterom & Strackee 1983,
// triangle fan), to check the spherical rectangle parametrisation independently.
double polygon_solid_angle(const std::vector<Vec3f>& poly, Vec3f o) {
  double omega = 0;
  Vec3f a = poly[0] - o;
  for (size_t i = 1; i + 1 < poly.size(); ++i) {
    Vec3f b = poly[i] - o, c = poly[i + 1] - o;
    double la = length(a), lb = length(b), lc = length(c);
    double num = dot(a, cross(b, c));
    double den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    omega += 2 * std::atan2(std::abs(num), den);
  }
  return omega;
}

TEST(AreaLight, SphericalRectangleSamplingIsUniformInSolidAngle) {
  AreaLight l = rect({0.3f, 1.2f, -0.2f}, 1.5f, 0.8f);
  Vec3f p(0.1f, 0.0f, 0.4f);
  double omega = polygon_solid_angle(l.outline(), p);
  Rng rng(3);
  for (int i = 0; i < 200; ++i) {
    AreaLight::DirectionSample ds;
    ASSERT_TRUE(l.sample_direction(p, rng.next_2d(), &ds));
    EXPECT_NEAR(ds.pdf, 1.0 / omega, 1e-3 / omega);
    Vec3f q = p + ds.dir * ds.dist;  // on the light's plane, inside the rectangle
    Vec3f local = l.frame.to_local(q - l.center);
    EXPECT_NEAR(local.z, 0.0f, 1e-4f);
    EXPECT_LE(std::abs(local.x), 0.75f + 1e-4f);
    EXPECT_LE(std::abs(local.y), 0.4f + 1e-4f);
  }
}

TEST(AreaLight, SolidAngleEstimatorConvergesToClosedForm) {
  // The reference's irradiance estimator (1024 stratified solid-angle samples) against
  // the closed form, for a tilted receiver: within 0.5%.
  AreaLight l = rect({0, 1.0f, 0}, 1.6f, 1.2f);
  Vec3f p(0.4f, 0, -0.3f), n = normalize(Vec3f(0.3f, 1, 0.2f));
  Rng rng(11);
  const int N = 1024;
  double e = 0, wsum = 0;
  for (int i = 0; i < N; ++i) {
    AreaLight::DirectionSample ds;
    ASSERT_TRUE(l.sample_direction(p, stratified_sample(i, N, rng.next_2d()), &ds));
    e += std::max(0.0f, dot(n, ds.dir)) / ds.pdf;
    wsum += ds.area_weight;
  }
  double expected = l.unshadowed_irradiance_scalar(p, n);
  EXPECT_NEAR(e / N, expected, 5e-3 * expected);
  // The area weights average to 1 (they are the ratio of two densities).
  EXPECT_NEAR(wsum / N, 1.0, 5e-3);
}

TEST(AreaLight, DiskAndSphereEstimatorsConvergeToClosedForms) {
  // The reference's estimators with 1024 stratified samples, for the other two shapes:
  // within 0.5% of the closed forms, on a tilted receiver.
  AreaLight disk;
  disk.shape = LightShape::Disk;
  disk.center = {0.2f, 1.4f, 0.1f};
  disk.frame = Frame::from_z(normalize(Vec3f(0.2f, -1, 0.1f)));
  disk.radius = 0.6f;
  AreaLight sphere;
  sphere.shape = LightShape::Sphere;
  sphere.center = {-0.3f, 1.8f, 0.2f};
  sphere.radius = 0.5f;
  Vec3f p(0.4f, 0, -0.3f), n = normalize(Vec3f(0.3f, 1, 0.2f));
  for (const AreaLight* l : {&disk, &sphere}) {
    LightPointSampler sampler(*l, p);
    ASSERT_TRUE(sampler.valid());
    Rng rng(23);
    const int N = 1024;
    StratifiedGrid grid(N);
    double e = 0;
    for (int i = 0; i < N; ++i) {
      AreaLight::DirectionSample ds;
      ASSERT_TRUE(sampler.sample(grid.sample(i, rng.next_2d()), &ds));
      e += std::max(0.0f, dot(n, ds.dir)) / ds.pdf;
    }
    double expected = l->unshadowed_irradiance_scalar(p, n);
    EXPECT_NEAR(e / N, expected, 5e-3 * expected) << to_string(l->shape);
  }
}

TEST(AreaLight, OneSidedLightsDoNotLightTheirBack) {
  AreaLight l = rect({0, 1, 0}, 1, 1);
  AreaLight::DirectionSample ds;
  EXPECT_FALSE(l.sample_direction({0, 2, 0}, {0.5f, 0.5f}, &ds));
  EXPECT_EQ(l.unshadowed_irradiance_scalar({0, 2, 0}, {0, -1, 0}), 0.0f);
}

}  // namespace
}  // namespace penumbra
