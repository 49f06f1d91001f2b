// Ellipsoid lights across the methods: each method either handles one (through the light's
// sampling, outline and extent, which AreaLight carries over from the unit sphere by its
// map A) within its measured error, or is one of the methods that refuse it by design, with a
// one-line error naming the shape; never a silent NaN, never an unexpected error.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/testing/test_scenes.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

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

// Each method's mean |V - reference| under the ellipsoid light (0.6 x 0.25 x 0.2) over an open
// quad and a closed box, 48 x 48, 64 light samples against the reference at 256, measured on
// 2026-11-27; a method is held to its value + 25% (render/regression_test.cpp holds every method
// to its error on the shipped scenes the same way). The exact-per-sample methods (afsm, ssv-rt)
// differ from the reference by more than its own noise because they sample the ellipsoid on its
// central ellipse (docs/methods/alias-free.md); the hard-shadow methods by the penumbra.
struct EllipsoidBound {
  const char* method;
  double measured;
};
constexpr EllipsoidBound kEllipsoidErrors[] = {
    {"afsm", 0.0051},        {"afsm-hard", 0.0422},     {"evsm", 0.0076},          {"hard", 0.0422},
    {"lam", 0.0057},         {"mlsm", 0.0026},          {"msm", 0.0072},           {"mtsm", 0.0026},
    {"multi-view-sm", 0.0053}, {"occlusion-textures", 0.0052}, {"pcss", 0.0053},   {"reference", 0.0026},
    {"rt-denoised", 0.0138}, {"shadow-map", 0.0422},    {"single-sample", 0.1494}, {"ssv-rt", 0.0051},
    {"vsm", 0.0063},
};
// The methods that refuse an ellipsoid light, by design, with the message's words.
constexpr const char* kRefusals[][2] = {{"coherent-rt", "does not support ellipsoid lights"}};

TEST(EllipsoidLight, EveryMethodHandlesItWithinItsBoundOrRefusesByDesign) {
  const LitScene r = make_run(ellipsoid_light_down({0.3f, 2.2f, 0.1f}, {0.6f, 0.25f, 0.2f}), 48);
  const std::vector<float> truth = run_method(r, "reference", 256).v;
  for (const MethodInfo* info : MethodRegistry::all()) {
    const std::string& name = info->name;
    const auto refusal = std::find_if(std::begin(kRefusals), std::end(kRefusals), [&](auto& x) { return name == x[0]; });
    if (refusal != std::end(kRefusals)) {
      try {
        run_method(r, name, 64);
        ADD_FAILURE() << name << " renders an ellipsoid light now: give it a bound in kEllipsoidErrors";
      } catch (const Error& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find((*refusal)[1]), std::string::npos) << name << ": " << msg;
        EXPECT_EQ(msg.find('\n'), std::string::npos) << name;
      }
      continue;
    }
    const auto row = std::find_if(std::begin(kEllipsoidErrors), std::end(kEllipsoidErrors),
                                  [&](const EllipsoidBound& b) { return name == b.method; });
    if (row == std::end(kEllipsoidErrors)) {
      ADD_FAILURE() << name << " has no bound in kEllipsoidErrors: measure it and add one";
      continue;
    }
    Result res;
    try {
      res = run_method(r, name, 64);
    } catch (const Error& e) {
      ADD_FAILURE() << name << " fails under an ellipsoid light: " << e.what();
      continue;
    }
    double mae = 0;
    for (size_t k = 0; k < truth.size(); ++k) {
      ASSERT_TRUE(std::isfinite(res.v[k]) && res.v[k] >= 0 && res.v[k] <= 1) << name << " " << res.v[k];
      mae += std::abs(res.v[k] - truth[k]);
    }
    mae /= truth.size();
    std::printf("%-22s mean |V - reference| %.4f (bound %.4f)\n", name.c_str(), mae, row->measured * 1.25);
    EXPECT_LE(mae, row->measured * 1.25) << name << " got worse under an ellipsoid light";
    if (mae * 1.25 < row->measured)
      std::printf("%-22s is better than its bound: tighten kEllipsoidErrors to %.4f\n", name.c_str(), mae);
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

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
