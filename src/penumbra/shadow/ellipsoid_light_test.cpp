// Ellipsoid lights across the methods: each method either handles one (through the light's
// sampling, outline and extent, which AreaLight carries over from the unit sphere by its
// map A) or refuses it with a one-line error naming the shape; never a silent NaN.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/testing/test_scenes.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {

using namespace penumbra::testing;

struct LitScene {
  Scene scene;
  std::unique_ptr<RayTracer> tracer;
  ViewSamples vs;
};

LitScene make_run(AreaLight light, int res) {
  LitScene r;
  r.scene = ground_scene({object(quad_y(0.9f, -1.0f, 0.2f, -0.6f, 0.4f)), object(box({0.4f, 0, -0.5f}, {0.9f, 0.6f, 0.2f}))},
                         light, res);
  r.tracer = std::make_unique<RayTracer>(r.scene);
  r.vs = camera_pass(r.scene, *r.tracer, 1);
  return r;
}

struct Result {
  std::vector<float> v;
  std::vector<Vec3f> e;
};

Result run_method(const LitScene& r, const std::string& method, int spp) {
  auto m = create_method(method, r.scene, {});
  ShadowContext ctx;
  ctx.scene = &r.scene;
  ctx.light = &r.scene.lights[0];
  ctx.tracer = r.tracer.get();
  ctx.light_samples = spp;
  m->prepare(ctx);
  Result out{std::vector<float>(r.vs.size(), -1.0f), std::vector<Vec3f>(r.vs.size())};
  ShadowOutput o{out.v, out.e};
  m->evaluate(ctx, r.vs, o);
  return out;
}

double mean(const std::vector<float>& v) {
  double s = 0;
  for (float x : v) s += x;
  return v.empty() ? 0 : s / v.size();
}

TEST(EllipsoidLight, EveryMethodHandlesItOrSaysSo) {
  const LitScene r = make_run(ellipsoid_light_down({0.3f, 2.2f, 0.1f}, {0.6f, 0.25f, 0.2f}), 48);
  const std::vector<float> truth = run_method(r, "reference", 256).v;
  for (const MethodInfo* info : MethodRegistry::all()) {
    Result res;
    try {
      res = run_method(r, info->name, 64);
    } catch (const Error& e) {
      const std::string msg = e.what();
      std::printf("%-22s refuses: %s\n", info->name.c_str(), msg.c_str());
      EXPECT_NE(msg.find("ellipsoid"), std::string::npos) << info->name << ": " << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << info->name;
      continue;
    }
    double mae = 0;
    for (size_t k = 0; k < truth.size(); ++k) {
      ASSERT_TRUE(std::isfinite(res.v[k]) && res.v[k] >= 0 && res.v[k] <= 1) << info->name << " " << res.v[k];
      mae += std::abs(res.v[k] - truth[k]);
    }
    mae /= truth.size();
    std::printf("%-22s mean |V - reference| %.4f\n", info->name.c_str(), mae);
    // Loose: the approximate methods differ from the truth, but not like a wrong light
    // (single-sample, parker1998's one-sample approximation, is off by 0.25 here with a sphere
    // light of the ellipsoid's largest radius too; the others are within 0.05).
    EXPECT_LT(mae, info->name == "single-sample" ? 0.3 : 0.1) << info->name;
  }
}

TEST(EllipsoidLight, ReferenceWithEqualRadiiMatchesTheSphere) {
  AreaLight sphere = rect_light_down({0.3f, 2.2f, 0.1f}, 1, 1);
  sphere.shape = LightShape::Sphere;
  sphere.radius = 0.4f;
  const LitScene s = make_run(sphere, 48);
  AreaLight e = s.scene.lights[0];  // the sphere's frame, set by Scene::finalize
  e.shape = LightShape::Ellipsoid;
  e.radii = Vec3f(0.4f);
  const LitScene el = make_run(e, 48);
  const Result a = run_method(s, "reference", 1024), b = run_method(el, "reference", 1024);
  double dv = 0, de = 0, esum = 0;
  for (size_t k = 0; k < a.v.size(); ++k) {
    dv += std::abs(a.v[k] - b.v[k]);
    de += std::abs(a.e[k].x - b.e[k].x);
    esum += a.e[k].x;
  }
  dv /= a.v.size();
  std::printf("reference, sphere vs ellipsoid of equal radii: mean |dV| %.4f, relative |dE| %.4f\n", dv, de / esum);
  EXPECT_LT(dv, 0.01);
  EXPECT_LT(de / esum, 0.01);
  EXPECT_NEAR(mean(a.v), mean(b.v), 0.003);
}

TEST(EllipsoidLight, ReferenceIrradianceOfLitPointsIsTheClosedForm) {
  const LitScene r = make_run(ellipsoid_light_down({0.3f, 2.2f, 0.1f}, {0.6f, 0.25f, 0.2f}), 48);
  const Result res = run_method(r, "reference", 1024);
  const AreaLight& l = r.scene.lights[0];
  int lit = 0;
  for (size_t k = 0; k < res.v.size(); ++k) {
    if (res.v[k] < 1.0f) continue;
    const ViewSample& s = r.vs.samples[k];
    const float expected = l.unshadowed_irradiance_scalar(s.p, s.ns);
    EXPECT_NEAR(res.e[k].x, expected, 0.01f * expected) << k;
    ++lit;
  }
  EXPECT_GT(lit, 200);
}

}  // namespace
}  // namespace penumbra
