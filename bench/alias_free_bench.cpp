// Alias-free shadow maps and sample-based soft visibility (sintorn2008), side by side with
// `multi-view-sm` (one shadow map per light sample) and `reference` (Embree rays) at the
// same number N of light samples: the paper's Fig. 13 (time vs light samples, against one
// shadow map per sample), Fig. 12 (time vs light size) and Fig. 11 (triangle count: knot
// tessellations), on knot.json at 256^2 view samples.
//
//   cmake --build build --target alias_free_bench -j2
//   build/alias_free_bench --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
//
// Each benchmark times ShadowMethod::evaluate() alone (prepare, which gathers triangles, is
// outside); "Time" is wall-clock, "CPU" the CPU time of the whole process (all threads).
// Counters: the afsm statistics (sample tests, texel visits, list occupancy).
#include <benchmark/benchmark.h>

#include <map>
#include <memory>

#include "penumbra/eval/run_setup.h"
#include "penumbra/render/renderer.h"

namespace penumbra {
namespace {

constexpr int kResolution = 256;

struct Fixture {
  Scene scene;
  std::unique_ptr<RayTracer> tracer;
  ViewSamples vs;
};

// knot.json at kResolution^2 with the given settings ("light.size_scale=2", ...).
Fixture& fixture(const std::vector<std::string>& settings) {
  static std::map<std::vector<std::string>, std::unique_ptr<Fixture>> cache;
  auto& f = cache[settings];
  if (!f) {
    RunSetup setup = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/knot.json");
    setup.apply("resolution", std::to_string(kResolution));
    for (const std::string& s : settings) setup.apply(s);
    f = std::make_unique<Fixture>();
    f->scene = setup.load();
    f->tracer = std::make_unique<RayTracer>(f->scene);
    f->vs = camera_pass(f->scene, *f->tracer, 0);
  }
  return *f;
}

void run(benchmark::State& state, const std::string& method, int spp, const std::vector<std::string>& settings) {
  Fixture& f = fixture(settings);
  ShadowContext ctx;
  ctx.scene = &f.scene;
  ctx.light = &f.scene.lights[0];
  ctx.tracer = f.tracer.get();
  ctx.light_samples = spp;
  auto m = create_method(method, f.scene, {});
  m->prepare(ctx);
  std::vector<float> v(f.vs.size());
  std::vector<Vec3f> e(f.vs.size());
  ShadowOutput out{v, e};
  for (auto _ : state) {
    m->stats() = MethodStats{};
    m->evaluate(ctx, f.vs, out);
  }
  state.counters["triangles"] = static_cast<double>(f.scene.triangle_count());
  state.counters["view_samples"] = static_cast<double>(f.vs.size());
  const nlohmann::json& x = m->stats().extra;
  for (const char* key : {"sample_tests", "texel_visits", "casters", "casters_skipped", "list_average", "list_max",
                          "exact_sample_tests"})
    if (x.contains(key)) state.counters[key] = x[key].get<double>();
  for (const char* phase : {"regions", "raster", "lists"})
    if (m->stats().phase(phase) > 0) state.counters[std::string(phase) + "_ms"] = m->stats().phase(phase);
}

void add(const std::string& name, const std::string& method, int spp, std::vector<std::string> settings) {
  auto* b = benchmark::RegisterBenchmark(name.c_str(), [=](benchmark::State& s) { run(s, method, spp, settings); });
  b->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
  // The slow ones (reference and multi-view-sm at high N) take seconds per run.
  if (method != "afsm" && method != "afsm-hard") b->Iterations(1);
}

void register_all() {
  const std::vector<std::string> soft = {"afsm", "multi-view-sm", "reference"};
  // Fig. 13: time vs light samples.
  for (int n : {64, 128, 256, 512, 1024})
    for (const std::string& m : soft) add("samples/" + m + "/" + std::to_string(n), m, n, {});
  // Fig. 12: time vs light size (N = 256).
  for (const char* scale : {"0.25", "0.5", "1", "2"})
    for (const std::string& m : soft)
      add(std::string("light_size_scale/") + m + "/" + scale, m, 256, {std::string("light.size_scale=") + scale});
  // Fig. 11, triangle count: knot tessellations (rings along the curve x 16 sides x 2), N = 256.
  for (int segments : {100, 200, 400, 800, 1600})
    for (const std::string& m : soft)
      add("knot_segments/" + m + "/" + std::to_string(segments), m, 256,
          {"generator.segments=" + std::to_string(segments)});
  // Hard shadows: afsm-hard against a shadow map and Embree rays to the centre.
  for (const std::string& m : {"afsm-hard", "shadow-map", "hard"}) add("hard/" + m, m, 1, {});
}

}  // namespace
}  // namespace penumbra

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  penumbra::register_all();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
