// Layered attenuation maps (agrawala2000 §4): precompute time for 64 and 256 light samples,
// display time per 512^2 frame, and the ratio of display to a `reference` render at 256
// samples per point, on the bunny and the plant.
//
//   cmake --build build --target lam_bench -j2
//   build/lam_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// BM_LamPrecompute: ShadowMethod::prepare (fit, one depth map per light sample, warp,
// insert, finalize). BM_LamDisplay: ShadowMethod::evaluate alone over the view samples of a
// 512^2 frame (what the 33 ms budget is about). BM_LamFrame: a whole
// Renderer::render() after the LDI exists (camera pass + display + compose), with each
// phase as a counter. BM_Reference256: the reference's evaluate at 256 spp (one iteration:
// it takes seconds), with the ratio display / reference as a counter.
//
// "Time" is wall-clock time; "CPU" is the CPU time of the whole process (all threads), so
// on a machine shared with other jobs CPU / threads is what the run would take on idle
// cores.
#include <benchmark/benchmark.h>

#include <map>
#include <memory>

#include "bench_fixture.h"
#include "penumbra/core/timer.h"
#include "penumbra/render/renderer.h"

namespace penumbra {
namespace {

constexpr int kResolution = 512;

std::map<std::string, double>& display_ms() {
  static std::map<std::string, double> m;
  return m;
}

bench::SceneFixture& fixture(const std::string& name) { return bench::scene_fixture(name, kResolution); }

void BM_LamPrecompute(benchmark::State& state, const std::string& name) {
  bench::SceneFixture& f = fixture(name);
  const int spp = static_cast<int>(state.range(0));
  const ShadowContext ctx = bench::shadow_context(f, spp);
  nlohmann::json extra;
  for (auto _ : state) {
    auto m = create_method("lam", f.scene, {});
    m->prepare(ctx);
    // evaluate() attaches the LDI's statistics; one sample is enough.
    state.PauseTiming();
    ViewSamples one;
    one.samples.push_back(f.view_samples.samples[0]);
    std::vector<float> v(1);
    std::vector<Vec3f> e(1);
    ShadowOutput out{v, e};
    m->evaluate(ctx, one, out);
    extra = m->stats().extra;
    state.ResumeTiming();
  }
  const auto& ms = extra["precompute_ms"];
  for (const char* k : {"raster", "warp", "insert", "finalize"}) state.counters[std::string(k) + "_ms"] = ms[k].get<double>();
  state.counters["depth_complexity"] = extra["depth_complexity"].back()["depth_complexity"].get<double>();
  state.counters["ldi_layers"] = extra["ldi"]["layers"].get<double>();
  state.counters["triangles"] = static_cast<double>(f.scene.triangle_count());
}

void BM_LamDisplay(benchmark::State& state, const std::string& name, const std::string& filter) {
  bench::SceneFixture& f = fixture(name);
  const ShadowContext ctx = bench::shadow_context(f, 64);
  auto m = create_method("lam", f.scene, {"filter=" + filter});
  m->prepare(ctx);
  std::vector<float> v(f.view_samples.size());
  std::vector<Vec3f> e(f.view_samples.size());
  ShadowOutput out{v, e};
  for (auto _ : state) m->evaluate(ctx, f.view_samples, out);
  state.counters["view_samples"] = static_cast<double>(f.view_samples.size());
  if (filter == "bilinear") {
    // Recorded for the reference ratio below (the last repetition's mean).
    double total = 0;
    int n = 0;
    for (int i = 0; i < 20; ++i, ++n) {
      Timer t;
      m->evaluate(ctx, f.view_samples, out);
      total += t.elapsed_ms();
    }
    display_ms()[name] = total / n;
  }
}

void BM_LamFrame(benchmark::State& state, const std::string& name) {
  bench::SceneFixture& f = fixture(name);
  RenderSettings settings;
  settings.method = "lam";
  settings.light_samples = 64;
  Renderer renderer(f.scene, settings);
  renderer.render();  // precompute
  double cam = 0, display = 0, compose = 0;
  int frames = 0;
  for (auto _ : state) {
    RenderResult r = renderer.render();
    cam += r.camera_pass_ms;
    display += r.stats.phase("display");
    compose += r.stats.phase("compose");
    ++frames;
  }
  state.counters["camera_pass_ms"] = cam / frames;
  state.counters["display_ms"] = display / frames;
  state.counters["compose_ms"] = compose / frames;
}

void BM_Reference256(benchmark::State& state, const std::string& name) {
  bench::SceneFixture& f = fixture(name);
  const ShadowContext ctx = bench::shadow_context(f, 256);
  auto m = create_method("reference", f.scene, {});
  m->prepare(ctx);
  std::vector<float> v(f.view_samples.size());
  std::vector<Vec3f> e(f.view_samples.size());
  ShadowOutput out{v, e};
  double ms = 0;
  for (auto _ : state) {
    Timer t;
    m->evaluate(ctx, f.view_samples, out);
    ms = t.elapsed_ms();
  }
  auto it = display_ms().find(name);
  if (it != display_ms().end()) {
    state.counters["lam_display_ms"] = it->second;
    state.counters["display_over_reference"] = it->second / ms;
    state.counters["speedup"] = ms / it->second;
  }
}

void register_all() {
  for (std::string scene : {"bunny", "plant"}) {
    benchmark::RegisterBenchmark(("BM_LamPrecompute/" + scene).c_str(), BM_LamPrecompute, scene)
        ->Arg(64)->Arg(256)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime()->Iterations(3);
    for (std::string filter : {"nearest", "bilinear"})
      benchmark::RegisterBenchmark(("BM_LamDisplay/" + scene + "/" + filter).c_str(), BM_LamDisplay, scene, filter)
          ->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
    benchmark::RegisterBenchmark(("BM_LamFrame/" + scene).c_str(), BM_LamFrame, scene)
        ->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
    benchmark::RegisterBenchmark(("BM_Reference256/" + scene).c_str(), BM_Reference256, scene)
        ->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime()->Iterations(1);
  }
}

}  // namespace
}  // namespace penumbra

int main(int argc, char** argv) { return penumbra::bench::run_benchmarks(argc, argv, penumbra::register_all); }
