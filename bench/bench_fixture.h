// What the method benchmarks share: a suite scene (scenes/NAME.json) loaded once per process
// at a given resolution, with its Embree scene and its camera pass, a ShadowContext on its
// first light, CPU clocks, and the main() of benchmarks registered at run time. Each
// bench/*_bench.cpp is its own executable (CMakeLists.txt); this header is their common part.
#pragma once

#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <time.h>

#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/eval/run_setup.h"
#include "penumbra/render/renderer.h"

namespace penumbra::bench {

struct SceneFixture {
  Scene scene;
  std::unique_ptr<RayTracer> tracer;
  ViewSamples view_samples;
};

// scenes/<name>.json at resolution^2 with one camera sample per pixel, after `settings`
// (compare/sweep keys such as "light.size_scale=2" or "generator.segments=200",
// docs/compare.md); cached per (name, resolution, settings) for the process.
inline SceneFixture& scene_fixture(const std::string& name, int resolution,
                                   const std::vector<std::string>& settings = {}) {
  using Key = std::pair<std::pair<std::string, int>, std::vector<std::string>>;
  static std::map<Key, std::unique_ptr<SceneFixture>> cache;
  std::unique_ptr<SceneFixture>& f = cache[{{name, resolution}, settings}];
  if (!f) {
    RunSetup setup = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name + ".json");
    setup.apply("resolution", std::to_string(resolution));
    setup.apply("pixel_samples", "1");
    for (const std::string& s : settings) setup.apply(s);
    f = std::make_unique<SceneFixture>();
    f->scene = setup.load();
    f->tracer = std::make_unique<RayTracer>(f->scene);
    f->view_samples = camera_pass(f->scene, *f->tracer, 0);
  }
  return *f;
}

// The context a method sees for the fixture's first light at `light_samples` per point.
inline ShadowContext shadow_context(const SceneFixture& f, int light_samples) {
  ShadowContext ctx;
  ctx.scene = &f.scene;
  ctx.light = &f.scene.lights[0];
  ctx.tracer = f.tracer.get();
  ctx.light_samples = light_samples;
  return ctx;
}

// CPU time of the whole process (every thread), ms: on a shared machine wall time includes
// waiting for the cores; this does not.
inline double process_cpu_ms() {
  rusage u;
  getrusage(RUSAGE_SELF, &u);
  return (u.ru_utime.tv_sec + u.ru_stime.tv_sec) * 1e3 + (u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-3;
}

// This thread's CPU time, ms (clock_gettime: ns resolution, where getrusage counts ticks).
inline double thread_cpu_ms() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

// main() of a benchmark whose cases are registered by `register_all()` at run time.
inline int run_benchmarks(int argc, char** argv, void (*register_all)()) {
  ::benchmark::Initialize(&argc, argv);
  if (::benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  register_all();
  ::benchmark::RunSpecifiedBenchmarks();
  ::benchmark::Shutdown();
  return 0;
}

}  // namespace penumbra::bench
