// Ray tracing multilayer (transparent) shadow maps (xie2007): shadow time of `mlsm` and
// `mtsm` at 256 light samples per point against `reference` (Embree, the real geometry, 256
// samples) and `multi-view-sm` with 5 views (5 light samples: one depth map each), side by
// side on the bunny, the plant and the furball at 256^2; and the construction cost of a
// 5-layer map against a 1-layer map (xie2007 §4.2: "only on average 5 percent more").
//
//   cmake --build build --target multilayer_bench -j2
//   build/multilayer_bench --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
//
// BM_Shadow/<scene>/<method>: ShadowMethod::evaluate over the view samples of one frame
// (the map is built in the first, untimed, call and reused). Counter `over_reference`:
// this method's median / reference's on the same scene, in this run.
// BM_Build/<scene>/<method>/layers:<k>: map construction alone (the "build" phase:
// light-centre view, rasterization of k layers or of every fragment with §5.1 compression,
// quadtree), timed manually.
//
// "Time" is wall-clock time; "CPU" is the CPU time of the whole process (all threads).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <map>
#include <memory>

#include "bench_fixture.h"
#include "penumbra/core/timer.h"
#include "penumbra/render/renderer.h"

namespace penumbra {
namespace {

constexpr int kResolution = 128;

std::map<std::string, double>& reference_ms() {
  static std::map<std::string, double> m;
  return m;
}

bench::SceneFixture& fixture(const std::string& name) { return bench::scene_fixture(name, kResolution); }

void BM_Shadow(benchmark::State& state, const std::string& scene, const std::string& method, int spp) {
  bench::SceneFixture& f = fixture(scene);
  const ShadowContext ctx = bench::shadow_context(f, spp);
  auto m = create_method(method, f.scene, {});
  m->prepare(ctx);
  std::vector<float> v(f.view_samples.size());
  std::vector<Vec3f> e(f.view_samples.size());
  ShadowOutput out{v, e};
  m->evaluate(ctx, f.view_samples, out);  // builds the map (not timed)
  std::vector<double> times;
  for (auto _ : state) {
    Timer t;
    m->evaluate(ctx, f.view_samples, out);
    times.push_back(t.elapsed_ms());
  }
  std::sort(times.begin(), times.end());
  const double median = times[times.size() / 2];
  if (method == "reference") reference_ms()[scene] = median;
  auto it = reference_ms().find(scene);
  if (it != reference_ms().end()) state.counters["over_reference"] = median / it->second;
  state.counters["view_samples"] = static_cast<double>(f.view_samples.size());
  state.counters["rays_per_ms"] = m->stats().rays_traced / std::max(1e-9, m->stats().phase("trace") + m->stats().phase("display"));
  const auto& extra = m->stats().extra;
  if (extra.contains("trace")) state.counters["texels_per_ray"] = extra["trace"]["texels_per_ray"].get<double>();
}

void BM_Build(benchmark::State& state, const std::string& scene, const std::string& method) {
  bench::SceneFixture& f = fixture(scene);
  const ShadowContext ctx = bench::shadow_context(f, 1);
  const int k = static_cast<int>(state.range(0));
  const std::string key = method == "mlsm" ? "layers=" : "resets=";
  double bytes = 0;
  for (auto _ : state) {
    auto m = create_method(method, f.scene, {key + std::to_string(method == "mlsm" ? k : k - 1)});
    m->prepare(ctx);
    std::vector<float> v(f.view_samples.size());
    std::vector<Vec3f> e(f.view_samples.size());
    ShadowOutput out{v, e};
    m->evaluate(ctx, f.view_samples, out);  // builds, then traces 1 sample per point (not counted)
    state.SetIterationTime(m->stats().phase("build") / 1000.0);
    bytes = static_cast<double>(m->stats().memory_bytes);
  }
  state.counters["map_bytes"] = bytes;
}

void register_all() {
  for (std::string scene : {"bunny", "plant", "furball"}) {
    // reference first: the ratios need its time.
    for (auto [method, spp] : std::vector<std::pair<std::string, int>>{
             {"reference", 256}, {"mlsm", 256}, {"mtsm", 256}, {"multi-view-sm", 5}})
      benchmark::RegisterBenchmark(("BM_Shadow/" + scene + "/" + method).c_str(), BM_Shadow, scene, method, spp)
          ->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime()->Iterations(3);
    for (std::string method : {"mlsm", "mtsm"})
      benchmark::RegisterBenchmark(("BM_Build/" + scene + "/" + method).c_str(), BM_Build, scene, method)
          ->ArgName("layers")->Arg(1)->Arg(5)->Unit(benchmark::kMillisecond)->UseManualTime()->Iterations(5);
  }
}

}  // namespace
}  // namespace penumbra

int main(int argc, char** argv) { return penumbra::bench::run_benchmarks(argc, argv, penumbra::register_all); }
