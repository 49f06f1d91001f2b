// The baselines side by side with `hard` and `reference`: one whole render (Embree BVH
// build, camera pass, prepare, evaluate, compose) of contact and bunny at 512x512, as
// `penumbra render` does it. Counter `method_ms`: the method's own phases (prepare +
// evaluate + compose), without the BVH build and the camera pass every method shares.
//
//   build/baselines_bench --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
//   build/baselines_bench --benchmark_filter='contact/'   # one scene
#include <benchmark/benchmark.h>

#include <map>
#include <memory>

#include "bench_fixture.h"
#include "penumbra/render/renderer.h"

namespace penumbra {
namespace {

constexpr int kResolution = 512;

const Scene& scene(const std::string& name) {
  static std::map<std::string, std::unique_ptr<Scene>> cache;
  auto& s = cache[name];
  if (!s) {
    s = std::make_unique<Scene>(load_scene(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name + ".json"));
    s->camera.width = s->camera.height = kResolution;
  }
  return *s;
}

struct Case {
  const char* label;
  const char* method;
  std::vector<std::string> params;
  int spp;
};

void BM_Render(benchmark::State& state, const std::string& scene_name, const Case& c) {
  const Scene& s = scene(scene_name);
  RenderSettings settings;
  settings.method = c.method;
  settings.params = c.params;
  settings.light_samples = c.spp;
  double method_ms = 0;
  for (auto _ : state) {
    RenderResult r = render_scene(s, settings);
    method_ms += r.stats.total_ms();
    benchmark::DoNotOptimize(r.visibility.data().data());
  }
  state.counters["method_ms"] = benchmark::Counter(method_ms, benchmark::Counter::kAvgIterations);
}

void register_all() {
  static const std::vector<Case> cases = {
      {"hard", "hard", {}, 1},
      {"shadow-map", "shadow-map", {}, 1},
      {"shadow-map-pcf2", "shadow-map", {"pcf=2"}, 1},
      {"pcss", "pcss", {}, 1},
      {"pcss-xie2007", "pcss", {"variant=xie2007"}, 1},
      {"multi-view-sm-64", "multi-view-sm", {}, 64},
      {"multi-view-sm-256", "multi-view-sm", {}, 256},
      {"reference-64", "reference", {}, 64},
      {"reference-256", "reference", {}, 256},
  };
  for (const char* name : {"contact", "bunny"})
    for (const Case& c : cases)
      benchmark::RegisterBenchmark((std::string(name) + "/" + c.label).c_str(), BM_Render, std::string(name), c)
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime()
          ->MeasureProcessCPUTime();
}

}  // namespace
}  // namespace penumbra

int main(int argc, char** argv) { return penumbra::bench::run_benchmarks(argc, argv, penumbra::register_all); }
