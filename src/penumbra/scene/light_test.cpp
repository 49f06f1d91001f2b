#include "penumbra/scene/light.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <tuple>
#include <utility>

#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"
#include "penumbra/scene/scene.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

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

// A disk tilted off the vertical and a sphere, both above the origin (the estimator and
// batch tests' other shapes).
AreaLight tilted_disk() {
  AreaLight disk;
  disk.shape = LightShape::Disk;
  disk.center = {0.2f, 1.4f, 0.1f};
  disk.frame = Frame::from_z(normalize(Vec3f(0.2f, -1, 0.1f)));
  disk.radius = 0.6f;
  return disk;
}

AreaLight sphere_light() {
  AreaLight sphere;
  sphere.shape = LightShape::Sphere;
  sphere.center = {-0.3f, 1.8f, 0.2f};
  sphere.radius = 0.5f;
  return sphere;
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
  AreaLight disk = tilted_disk();
  AreaLight sphere = sphere_light();
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

// ---- ellipsoid ------------------------------------------------------------------------

AreaLight ellipsoid(Vec3f center, Vec3f radii, Frame frame) {
  AreaLight l;
  l.shape = LightShape::Ellipsoid;
  l.center = center;
  l.radii = radii;
  l.frame = frame;
  return l;
}

// A squashed, tilted ellipsoid over the origin.
AreaLight squashed() {
  return ellipsoid({0.2f, 1.6f, -0.1f}, {0.8f, 0.3f, 0.15f},
                   Frame::from_zx(normalize(Vec3f(0.3f, -1, 0.2f)), normalize(Vec3f(1, 0.1f, 0.4f))));
}

// Brute force: L = 1, the integral of cos_p cos_l / r^2 over the surface elements facing p
// (the visible ones: the ellipsoid is convex), by stratified Monte Carlo (k x 2k jittered
// strata, uniform on the unit sphere) mapped by A: dA = r_s r_t r_n |S^-1 u| dA_unit, normal
// R S^-1 u / |S^-1 u|. In double: the integrand is steep next to the surface.
double surface_irradiance_mc(const AreaLight& l, Vec3f p, Vec3f n, int k, uint64_t seed) {
  Rng rng(seed);
  const double rad[3] = {l.radii.x, l.radii.y, l.radii.z};
  const Vec3f axes[3] = {l.frame.s, l.frame.t, l.frame.n};
  double sum = 0;
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < 2 * k; ++j) {
      const Vec2f u = rng.next_2d();
      const double z = 1 - 2 * (i + u.x) / k, r = std::sqrt(std::max(0.0, 1 - z * z)), phi = kPi * (j + u.y) / k;
      const double x[3] = {r * std::cos(phi), r * std::sin(phi), z};
      double m[3], lm = 0;
      for (int a = 0; a < 3; ++a) lm += (m[a] = x[a] / rad[a]) * m[a];
      lm = std::sqrt(lm);
      double d[3], nw[3], r2 = 0;
      for (int c = 0; c < 3; ++c) {
        const double pc = c == 0 ? p.x : c == 1 ? p.y : p.z;
        const double cc = c == 0 ? l.center.x : c == 1 ? l.center.y : l.center.z;
        double q = cc, nn = 0;
        for (int a = 0; a < 3; ++a) {
          const float ax = c == 0 ? axes[a].x : c == 1 ? axes[a].y : axes[a].z;
          q += ax * x[a] * rad[a];
          nn += ax * m[a] / lm;
        }
        d[c] = q - pc;
        nw[c] = nn;
        r2 += d[c] * d[c];
      }
      const double rr = std::sqrt(r2);
      const double cos_p = (d[0] * n.x + d[1] * n.y + d[2] * n.z) / rr;
      const double cos_l = -(d[0] * nw[0] + d[1] * nw[1] + d[2] * nw[2]) / rr;
      if (cos_p > 0 && cos_l > 0) sum += cos_p * cos_l / r2 * rad[0] * rad[1] * rad[2] * lm;
    }
  return sum * 4 * kPi / (2.0 * k * k);
}

TEST(AreaLightEllipsoid, EqualRadiiGiveTheSphere) {
  AreaLight sphere = sphere_light();
  sphere.frame = Frame::from_z(normalize(Vec3f(0.1f, -1, 0.05f)));
  const AreaLight e = ellipsoid(sphere.center, Vec3f(0.5f), sphere.frame);
  EXPECT_FLOAT_EQ(e.area(), sphere.area());
  EXPECT_FLOAT_EQ(e.diameter(), sphere.diameter());
  EXPECT_FLOAT_EQ(e.extent_radius(), sphere.extent_radius());
  Rng rng(5);
  for (int i = 0; i < 20; ++i) {
    const Vec2f u = rng.next_2d();
    EXPECT_LT(length(e.sample_area(u) - sphere.sample_area(u)), 1e-5f);
  }
  const std::vector<Vec3f> a = e.outline(12), b = sphere.outline(12);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_LT(length(a[i] - b[i]), 1e-5f);
  EXPECT_TRUE(e.faces({0, 0, 0}));
  EXPECT_FALSE(e.faces(sphere.center + Vec3f(0.49f, 0, 0)));
  // Irradiance: the closed form where the sphere is above the horizon (1e-3), its
  // quadrature where it straddles it.
  const Vec3f p(0.4f, 0, -0.3f);
  for (Vec3f n : {Vec3f(0, 1, 0), normalize(Vec3f(0.3f, 1, 0.2f)), normalize(Vec3f(1, 0.6f, 0))}) {
    const double expected = sphere.unshadowed_irradiance_scalar(p, n);
    EXPECT_NEAR(e.unshadowed_irradiance_scalar(p, n), expected, 1e-3 * expected) << n.x;
  }
  const Vec3f straddle = normalize(Vec3f(-1, 0.05f, 0.0f));
  const double expected = sphere.unshadowed_irradiance_scalar(p, straddle);
  ASSERT_GT(expected, 0);
  EXPECT_NEAR(e.unshadowed_irradiance_scalar(p, straddle), expected, 5e-3 * expected);
}

TEST(AreaLightEllipsoid, IrradianceEqualsTheSurfaceIntegral) {
  const AreaLight l = squashed();
  struct Case { Vec3f p, n; };
  const Case cases[] = {
      {{0, 0, 0}, {0, 1, 0}},
      {{0.9f, 0.2f, -0.6f}, normalize(Vec3f(-0.3f, 1, 0.2f))},
      {{-0.5f, 1.5f, 0.3f}, {1, 0, 0}},               // beside it, facing it
      {{0.2f, 1.4f, -0.1f}, normalize(Vec3f(1, 0.1f, 0))},  // under it, the horizon cuts it
  };
  for (const Case& c : cases) {
    ASSERT_TRUE(l.faces(c.p));
    const double mc = surface_irradiance_mc(l, c.p, c.n, 1500, 7);
    const double e = l.unshadowed_irradiance_scalar(c.p, c.n);
    ASSERT_GT(mc, 1e-3);
    EXPECT_NEAR(e, mc, 5e-3 * mc) << c.p.x << " " << c.p.y;
  }
  // Inside: nothing.
  EXPECT_EQ(l.unshadowed_irradiance_scalar(l.center, {0, 1, 0}), 0.0f);
}

TEST(AreaLightEllipsoid, SamplesLieOnTheEllipsoidsSections) {
  const AreaLight l = squashed();
  EXPECT_FLOAT_EQ(l.area(), kPi * 0.8f * 0.3f);
  EXPECT_FLOAT_EQ(l.diameter(), 1.6f);
  Rng rng(9);
  const Vec3f p(0.4f, 0, -0.3f);
  const Vec3f pu = l.to_unit_sphere(p);
  EXPECT_LT(length(l.from_unit_sphere(pu) - p), 1e-5f);
  const std::vector<Vec3f> outline = l.outline(8);
  for (int i = 0; i < 500; ++i) {
    const Vec2f u = rng.next_2d();
    // sample_area: the central ellipse facing frame.n, inside the outline polygon.
    const Vec3f q = l.sample_area(u);
    const Vec3f qu = l.to_unit_sphere(q);
    EXPECT_NEAR(qu.z, 0.0f, 1e-5f);
    EXPECT_LE(qu.x * qu.x + qu.y * qu.y, 1 + 1e-5f);
    const Vec3f ql = l.frame.to_local(q - l.center);
    for (size_t k = 0; k < outline.size(); ++k) {
      const Vec3f a = l.frame.to_local(outline[k] - l.center), b = l.frame.to_local(outline[(k + 1) % outline.size()] - l.center);
      EXPECT_GE((b.x - a.x) * (ql.y - a.y) - (b.y - a.y) * (ql.x - a.x), -1e-5f);
    }
    // sample_area_toward: the unit sphere's central disk perpendicular to A^-1(p), mapped.
    const Vec3f t = l.to_unit_sphere(l.sample_area_toward(u, p));
    EXPECT_NEAR(dot(t, normalize(pu)), 0.0f, 1e-5f);
    EXPECT_LE(length(t), 1 + 1e-5f);
  }
}

TEST(AreaLightEllipsoid, EstimatorConvergesToClosedFormAndCoversTheEllipsoid) {
  const AreaLight l = squashed();
  const Vec3f p(0.4f, 0, -0.3f), n = normalize(Vec3f(0.3f, 1, 0.2f));
  LightPointSampler sampler(l, p);
  ASSERT_TRUE(sampler.valid());
  Rng rng(23);
  const int N = 4096;
  StratifiedGrid grid(N);
  double e = 0, wsum = 0;
  const Vec3f pu = l.to_unit_sphere(p);
  for (int i = 0; i < N; ++i) {
    AreaLight::DirectionSample ds;
    ASSERT_TRUE(sampler.sample(grid.sample(i, rng.next_2d()), &ds));
    e += std::max(0.0f, dot(n, ds.dir)) / ds.pdf;
    wsum += ds.area_weight;
    // The ray hits the ellipsoid (in the unit sphere's space: |pu + t du|^2 = 1 has roots),
    // and its end point lies inside it.
    const Vec3f du = l.to_unit_sphere(p + ds.dir) - pu;
    const float b = dot(pu, du), a = dot(du, du), c = dot(pu, pu) - 1;
    EXPECT_GE(b * b - a * c, -1e-4f * a);
    EXPECT_LE(length(l.to_unit_sphere(p + ds.dir * ds.dist)), 1 + 1e-4f);
  }
  const double expected = l.unshadowed_irradiance_scalar(p, n);
  EXPECT_NEAR(e / N, expected, 5e-3 * expected);
  // The weights are 1/pdf up to a constant (self-normalised): about 1.
  EXPECT_GT(wsum / N, 0.7);
  EXPECT_LT(wsum / N, 1.3);
  // Inside the ellipsoid nothing is sampled.
  EXPECT_FALSE(LightPointSampler(l, l.center + Vec3f(0.05f, 0, 0)).valid());
}

TEST(AreaLight, OneSidedLightsDoNotLightTheirBack) {
  AreaLight l = rect({0, 1, 0}, 1, 1);
  AreaLight::DirectionSample ds;
  EXPECT_FALSE(l.sample_direction({0, 2, 0}, {0.5f, 0.5f}, &ds));
  EXPECT_EQ(l.unshadowed_irradiance_scalar({0, 2, 0}, {0, -1, 0}), 0.0f);
}

// ---- batched sampling ------------------------------------------------------------------

TEST(LightPointSampler, BatchEqualsScalarSampleForEveryShape) {
  // sample_batch (SIMD warps for rects and spheres, the scalar path for the rest) gives the
  // same light points and weights as sample(), from points near, far, off to the side and
  // grazing, for every shape.
  AreaLight r = rect({0.1f, 1.5f, -0.2f}, 2.0f, 0.7f);
  AreaLight sphere = sphere_light();
  AreaLight disk = tilted_disk();
  const Vec3f points[] = {{0, 0, 0}, {3.0f, 1.2f, -2.0f}, {0.3f, 1.45f, 0.1f}, {-20, -5, 30}, {0.05f, 0.9f, -0.1f}};
  const int n = 37;  // not a multiple of any vector width
  std::vector<float> ux(48), uy(48);
  Rng rng(5);
  for (int i = 0; i < n; ++i) {
    Vec2f u = rng.next_2d();
    ux[i] = u.x;
    uy[i] = u.y;
  }
  ux[0] = uy[0] = 0.0f;  // the corners of the square
  ux[1] = uy[1] = 0.99999994f;
  for (const AreaLight* l : {&r, &sphere, &disk}) {
    for (Vec3f p : points) {
      LightPointSampler sampler(*l, p);
      if (!sampler.valid()) continue;
      LightSampleBatch batch;
      const int m = sampler.sample_batch(ux.data(), uy.data(), n, batch);
      int k = 0;
      for (int i = 0; i < n; ++i) {
        AreaLight::DirectionSample ds;
        if (!sampler.sample({ux[i], uy[i]}, &ds)) continue;
        ASSERT_LT(k, m);
        const Vec3f q = ds.dir * ds.dist, qb(batch.x[k], batch.y[k], batch.z[k]);
        const float tol = 2e-4f * std::max(1.0f, ds.dist);
        EXPECT_NEAR(qb.x, q.x, tol) << to_string(l->shape) << " sample " << i;
        EXPECT_NEAR(qb.y, q.y, tol) << to_string(l->shape) << " sample " << i;
        EXPECT_NEAR(qb.z, q.z, tol) << to_string(l->shape) << " sample " << i;
        EXPECT_NEAR(batch.dist[k], ds.dist, tol);
        EXPECT_NEAR(batch.inv_pdf[k], 1.0f / ds.pdf, 1e-4f / ds.pdf);
        // The weight divides by the cosine at the light: from the grazing point it amplifies rounding.
        EXPECT_NEAR(batch.area_weight[k], ds.area_weight, 5e-4f * std::max(1.0f, ds.area_weight));
        ++k;
      }
      EXPECT_EQ(k, m) << to_string(l->shape);
    }
  }
}

TEST(AreaLight, BatchIrradianceEqualsScalarForEveryShape) {
  // The many-point form (a SIMD kernel for rects, with the scalar clipping formula for points
  // whose horizon cuts the light) equals the one-point form, for points under, beside, behind
  // and far from each light, with normals facing it, tilted across it and away from it.
  AreaLight r = rect({0.1f, 1.5f, -0.2f}, 2.0f, 0.7f);
  AreaLight disk = tilted_disk();
  AreaLight sphere = sphere_light();
  Rng rng(23);
  const size_t n = 301;  // not a multiple of any vector width, more than one chunk
  std::vector<Vec3f> p(n), nrm(n);
  for (size_t i = 0; i < n; ++i) {
    const Vec2f a = rng.next_2d(), b = rng.next_2d();
    const float scale = i % 7 == 0 ? 40.0f : 3.0f;  // some far points
    p[i] = Vec3f(scale * (a.x - 0.5f), 2.0f * a.y - 0.5f, scale * (b.x - 0.5f));
    nrm[i] = i % 5 == 0 ? Vec3f(0, 1, 0) : square_to_cone(rng.next_2d(), -1.0f);  // uniform on the sphere
  }
  for (const AreaLight* l : {&r, &disk, &sphere}) {
    std::vector<float> batch(n);
    l->unshadowed_irradiance_scalar(p, nrm, batch);
    int clipped = 0;
    for (size_t i = 0; i < n; ++i) {
      const float one = l->unshadowed_irradiance_scalar(p[i], nrm[i]);
      EXPECT_NEAR(batch[i], one, 1e-6f * std::max(one, 1e-3f)) << to_string(l->shape) << " point " << i;
      clipped += one > 0 && nrm[i].y != 1.0f;
    }
    EXPECT_GT(clipped, 20) << to_string(l->shape);  // the tilted normals did cross the light
  }
}

TEST(AreaLight, FarRectIrradianceKeepsItsDigits) {
  // 1000 light widths away the four edge terms of Lambert's formula cancel to one part in
  // 1e3, so both forms keep double precision through the sum (in float the result would be
  // off by percents); the SIMD kernel must agree with the closed form as the scalar one does.
  for (float h : {100.0f, 1000.0f, 5000.0f}) {
    AreaLight l = rect({0, h, 0}, 1, 1);
    const double expected = 4 * corner_rect_irradiance(0.5, 0.5, h);
    EXPECT_NEAR(l.unshadowed_irradiance_scalar({0, 0, 0}, {0, 1, 0}), expected, 1e-5 * expected) << h;
    std::vector<Vec3f> p(16, Vec3f(0.0f)), nrm(16, Vec3f(0, 1, 0));
    std::vector<float> e(16);
    l.unshadowed_irradiance_scalar(p, nrm, e);
    EXPECT_NEAR(e[3], expected, 1e-5 * expected) << h;
  }
}

// Issue 20 part 3: a textured rect's area samples follow its image (here a 2 x 2 image, one
// bright texel at the top right: v up, u along frame.s), and expand_textured_lights gives one
// light per non-zero channel, radiance = radiance x the channel's mean, each sampling its
// channel's table.
TEST(AreaLight, TexturedRectSamplesFollowTheImageAndExpandsPerChannel) {
  AreaLight l;
  l.shape = LightShape::Rect;
  l.center = {0, 3, 0};
  l.frame = Frame::from_zx({0, -1, 0}, {1, 0, 0});  // s = +x, t = +z
  l.size = {2, 1};
  l.radiance = {2, 2, 2};
  // Row 0 (top, v = 1): texel (1, 0) bright white; the others dim red.
  std::vector<float> rgba = {0.1f, 0, 0, 1, 3, 3, 3, 1,  // top row
                             0.1f, 0, 0, 1, 0.1f, 0, 0, 1};
  l.texture = std::make_shared<const LightTexture>(std::make_shared<const Texture>(2, 2, rgba, false, "t"));
  EXPECT_NEAR(l.texture->mean.x, (0.3f + 3) / 4, 1e-6f);
  EXPECT_NEAR(l.texture->mean.y, 3 / 4.0f, 1e-6f);
  const std::vector<AreaLight> lights = expand_textured_lights(std::span(&l, 1));
  ASSERT_EQ(lights.size(), 3u);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(lights[c].texture_channel, c);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(lights[c].radiance[k], k == c ? 2 * l.texture->mean[c] : 0.0f, 1e-6f);
  }
  // Green lives in the top-right texel only: x > 0 (u > 0.5), z > 0 (v > 0.5).
  Rng rng(3, 4);
  int red_top_right = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vec3f g = lights[1].sample_area(rng.next_2d());
    ASSERT_GT(g.x, 0.0f);
    ASSERT_GT(g.z, 0.0f);
    ASSERT_LE(g.x, 1.0f);
    ASSERT_LE(g.z, 0.5f);
    const Vec3f r = lights[0].sample_area(rng.next_2d());
    red_top_right += r.x > 0 && r.z > 0;
  }
  // Red: 3 of 3.3 in the top-right texel.
  EXPECT_NEAR(red_top_right / 4000.0, 3 / 3.3, 0.02);
  // The direction sampler of a textured light samples by area through the table, weighted as
  // uniform area samples: the irradiance estimate of the channel light is the closed form's.
  const Vec3f p{0.3f, 0, 0.2f}, n{0, 1, 0};
  const LightPointSampler sampler(lights[1], p);
  ASSERT_TRUE(sampler.valid());
  double e = 0;
  const int m = 20000;
  for (int i = 0; i < m; ++i) {
    AreaLight::DirectionSample ds;
    ASSERT_TRUE(sampler.sample(rng.next_2d(), &ds));
    const Vec3f q = p + ds.dir * ds.dist;
    EXPECT_GT(q.x, 0.0f);
    e += std::max(0.0f, dot(ds.dir, n)) / ds.pdf;
  }
  // Exact for the texture: the green emission of the top-right quarter, divided by its mean.
  AreaLight quarter = l;
  quarter.texture.reset();
  quarter.size = {1, 0.5f};
  quarter.center = {0.5f, 3, 0.25f};
  const double exact = quarter.unshadowed_irradiance_scalar(p, n) * 4;  // the quarter's emission / mean (1/4)
  EXPECT_NEAR(e / m, exact, 0.01 * exact);
}

// split_sphere_lights: every point of the scene's bounds is served by exactly one of the lights a
// sphere becomes, a point behind the sphere's disk by a face whose disk it sees within 54.7
// degrees of its axis; a sphere whose scene lies in front of its disk is kept as it is.
TEST(AreaLight, ASphereTheSceneReachesBehindIsSplitSoThatEveryPointHasOneFace) {
  AreaLight sphere;
  sphere.shape = LightShape::Sphere;
  sphere.radius = 0.2f;
  const auto split = [&](Vec3f center, const Bounds3f& bounds) {
    AreaLight l = sphere;
    l.center = center;
    std::vector<AreaLight> lights = {l};
    orient_sphere_lights(lights, bounds);
    return std::pair(lights[0], split_sphere_lights(lights, bounds));
  };
  Bounds3f room;
  room.extend(Vec3f(-2, 0, -2));
  room.extend(Vec3f(2, 2.5f, 2));
  Bounds3f ground;
  ground.extend(Vec3f(-4, 0, -4));
  ground.extend(Vec3f(4, 1, 4));

  // Above a ground that lies in front of its disk: kept.
  const auto [above, kept] = split(Vec3f(0, 3, 0), ground);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_EQ(kept[0].split_face, -1);
  EXPECT_EQ(whole_light_count(kept), 1.0f);

  // In a room (inside the bounds): the whole cube, six faces. Beside a ground that reaches behind
  // its disk (outside the bounds): the light as it was for the front, faces behind.
  for (const auto& [center, bounds, cube] : {std::tuple(Vec3f(0, 1.6f, 0), room, true),
                                             std::tuple(Vec3f(3.5f, 1.5f, 0.5f), ground, false)}) {
    const auto [whole, faces] = split(center, bounds);
    ASSERT_GE(faces.size(), 2u);
    if (cube) EXPECT_EQ(faces.size(), 6u);
    EXPECT_FLOAT_EQ(whole_light_count(faces), 1.0f);
    for (const AreaLight& f : faces) {
      EXPECT_EQ(f.split_cube, cube);
      EXPECT_EQ(f.split_faces, static_cast<int>(faces.size()));
      EXPECT_NEAR(dot(cross(f.frame.s, f.frame.t), f.frame.n), 1.0f, 1e-5f);  // right-handed
      EXPECT_EQ(f.center, whole.center);
    }
    if (!cube) {  // the front is the light as it was
      EXPECT_EQ(faces[0].split_face, 0);
      EXPECT_EQ(faces[0].frame.n, whole.frame.n);
    }
    Rng rng(5);
    for (int i = 0; i < 20000; ++i) {
      const Vec3f p = bounds.lo + bounds.diagonal() * Vec3f(rng.next_float(), rng.next_float(), rng.next_float());
      int serving = 0;
      for (const AreaLight& f : faces) {
        if (!f.serves(p)) continue;
        ++serving;
        const float cos_axis = dot(normalize(p - center), f.frame.n);
        if (cube || f.split_face > 0)
          EXPECT_GE(cos_axis, 1.0f / std::sqrt(3.0f) - 1e-4f) << "face " << f.split_face;
        else
          EXPECT_GE(cos_axis, 0.0f);
      }
      ASSERT_EQ(serving, 1) << p.x << " " << p.y << " " << p.z;
    }
  }
}

// An ellipsoid is split alike (its frame is its semi-axes', given by the scene): every face is the
// same ellipsoid, in a frame whose n is the face's axis, so its inside, its closed-form
// irradiance and its tangent cone are the whole light's.
TEST(AreaLight, AnEllipsoidTheSceneReachesBehindIsSplitIntoTheSameEllipsoid) {
  AreaLight e;
  e.shape = LightShape::Ellipsoid;
  e.center = Vec3f(0.3f, 1.6f, 0.2f);
  e.frame = Frame::from_zx(normalize(Vec3f(0.2f, -1.0f, 0.1f)), Vec3f(1, 0, 0));
  e.radii = Vec3f(0.3f, 0.12f, 0.06f);
  Bounds3f room;
  room.extend(Vec3f(-3, 0, -3));
  room.extend(Vec3f(3, 3, 3));
  const std::vector<AreaLight> faces = split_sphere_lights(std::span(&e, 1), room);
  ASSERT_EQ(faces.size(), 6u);
  Rng rng(9);
  for (int i = 0; i < 2000; ++i) {
    const Vec3f p = room.lo + room.diagonal() * Vec3f(rng.next_float(), rng.next_float(), rng.next_float());
    const Vec3f n = normalize(Vec3f(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f));
    const float whole = e.unshadowed_irradiance_scalar(p, n);
    int serving = 0;
    for (const AreaLight& f : faces) {
      EXPECT_EQ(f.faces(p), e.faces(p));
      EXPECT_NEAR(f.unshadowed_irradiance_scalar(p, n), whole, 1e-4f * whole + 1e-7f);
      EXPECT_NEAR(length(f.from_unit_sphere(f.to_unit_sphere(p)) - p), 0.0f, 1e-4f);
      serving += f.serves(p) ? 1 : 0;
    }
    ASSERT_EQ(serving, 1);
  }
  // Each face's surface is the whole light's: a point of its unit sphere maps onto the ellipsoid.
  for (const AreaLight& f : faces)
    for (int i = 0; i < 200; ++i) {
      const Vec3f x = normalize(Vec3f(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f));
      EXPECT_NEAR(length(e.to_unit_sphere(f.from_unit_sphere(x))), 1.0f, 1e-4f) << "face " << f.split_face;
    }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
