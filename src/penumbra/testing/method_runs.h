// Running one method on a scene's view samples and comparing it with Embree shadow rays to
// exactly the light points it uses: what the exact-visibility methods (afsm, ssv-rt) are
// tested against, on every view sample. Header-only; tests only.
#pragma once

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/core/parallel.h"
#include "penumbra/eval/run_setup.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/shadow/shadow_rays.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra::testing {

struct SceneRun {
  Scene scene;
  std::unique_ptr<RayTracer> tracer;
  ViewSamples vs;
};

inline SceneRun load_scene_at(const std::string& name, int resolution) {
  RunSetup setup = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name + ".json");
  setup.apply("resolution", std::to_string(resolution));
  SceneRun r;
  r.scene = setup.load();
  r.tracer = std::make_unique<RayTracer>(r.scene);
  r.vs = camera_pass(r.scene, *r.tracer, 1);
  return r;
}

inline SceneRun build_scene_run(Scene scene) {
  SceneRun r;
  r.scene = std::move(scene);
  r.tracer = std::make_unique<RayTracer>(r.scene);
  r.vs = camera_pass(r.scene, *r.tracer, 1);
  return r;
}

inline std::vector<float> run_method(const SceneRun& r, const std::string& method, int spp,
                              std::vector<std::string> params = {}, MethodStats* stats = nullptr,
                                     uint64_t seed = 0) {
  auto m = create_method(method, r.scene, params);
  ShadowContext ctx;
  ctx.scene = &r.scene;
  ctx.light = &r.scene.lights[0];
  ctx.tracer = r.tracer.get();
  ctx.light_samples = spp;
  ctx.seed = seed;
  m->prepare(ctx);
  std::vector<float> v(r.vs.size(), -1.0f);
  std::vector<Vec3f> e(r.vs.size());
  ShadowOutput out{v, e};
  m->evaluate(ctx, r.vs, out);
  if (stats) *stats = m->stats();
  return v;
}

inline bool in_front(const AreaLight& l, Vec3f p) { return dot(p - l.center, l.frame.n) > 0; }

// Embree: hard shadow rays to the light's centre.
inline std::vector<float> embree_hard(const SceneRun& r) {
  const AreaLight& light = r.scene.lights[0];
  std::vector<float> v(r.vs.size());
  transmittance_to_point(*r.tracer, r.vs, light.center, v);
  for (size_t k = 0; k < v.size(); ++k)
    if (!in_front(light, r.vs.samples[k].p)) v[k] = 0;
  return v;
}

// Embree: the fraction of exactly the method's N light points each view sample sees.
inline std::vector<float> embree_to_points(const SceneRun& r, const std::vector<Vec3f>& points) {
  const AreaLight& light = r.scene.lights[0];
  std::vector<float> v(r.vs.size(), 0.0f);
  parallel_for(r.vs.size(), 64, [&](size_t begin, size_t end) {
    std::vector<ShadowRay> rays(points.size());
    std::vector<float> t(points.size());
    for (size_t k = begin; k < end; ++k) {
      const ViewSample& s = r.vs.samples[k];
      if (!in_front(light, s.p)) continue;
      for (size_t i = 0; i < points.size(); ++i) rays[i] = shadow_ray_to(s.p, s.ng, points[i]);
      r.tracer->transmittance(rays, t);
      double sum = 0;
      for (float x : t) sum += x;
      v[k] = static_cast<float>(sum / points.size());
    }
  });
  return v;
}

struct Agreement {
  double equal_fraction = 0;
  float max_diff = 0;
  size_t worst = 0;  // the index of a value with the largest difference
};

inline Agreement agreement(const std::vector<float>& a, const std::vector<float>& b) {
  size_t equal = 0;
  Agreement g;
  for (size_t k = 0; k < a.size(); ++k) {
    const float d = std::abs(a[k] - b[k]);
    if (d < 1e-6f) equal++;
    if (d > g.max_diff) g.max_diff = d, g.worst = k;
  }
  g.equal_fraction = a.empty() ? 1.0 : static_cast<double>(equal) / a.size();
  return g;
}

// One line naming view sample k of a run (for a failing comparison): its pixel, the object it
// lies on, its position and geometric normal, and the two values compared there.
inline std::string describe_sample(const SceneRun& r, size_t k, const std::vector<float>& a, const std::vector<float>& b) {
  const ViewSample& s = r.vs.samples[k];
  return fmt::format("view sample {} (pixel {}, {}) on '{}' at ({:.6g}, {:.6g}, {:.6g}), ng ({:.4g}, {:.4g}, {:.4g}): {} vs {}", k,
                     s.pixel % r.vs.width, s.pixel / r.vs.width, r.scene.objects[s.object].name, s.p.x, s.p.y, s.p.z,
                     s.ng.x, s.ng.y, s.ng.z, a[k], b[k]);
}
// The same for the worst sample of agreement(a, b).
inline std::string worst_sample(const SceneRun& r, const std::vector<float>& a, const std::vector<float>& b) {
  return "worst: " + describe_sample(r, agreement(a, b).worst, a, b);
}

}  // namespace penumbra::testing
