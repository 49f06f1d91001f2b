// parker1998's claim, measured: `single-sample` (one shadow ray plus the outer-object search)
// against `hard` (one shadow ray) and `reference` (256 light samples) on bunny, knot and
// plant at 512 x 512, side by side in one run; then the time ratios.
//
//   frame/<scene>/<method>   a whole frame through penumbra::render_scene, as a user's
//                            `penumbra render` runs it minus file I/O: the Embree build,
//                            the method's prepare() (single-sample: contour extraction and
//                            BVH), the camera pass, the shadow evaluation and compose.
//   warm/<scene>/<method>    Renderer::render() on a Renderer kept between frames: the
//                            light-space structures survive (architecture.md), so this is
//                            camera pass + evaluate + compose.
//   shadow/<scene>/<method>  evaluate() alone on one thread, in CPU time (the least noisy
//                            number on a shared machine; for profiling the method).
//
//   build/single_sample_bench --benchmark_enable_random_interleaving=true
//
// Ratios of medians are printed at the end (docs/methods/single-sample.md).
#include <benchmark/benchmark.h>

#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>

#include "penumbra/core/parallel.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene/scene.h"

namespace penumbra {
namespace {

constexpr int kResolution = 512;
constexpr int kReferenceSpp = 256;
const char* const kScenes[] = {"bunny", "knot", "plant"};

const Scene& scene(const std::string& name) {
  static std::map<std::string, Scene> cache;
  auto it = cache.find(name);
  if (it == cache.end()) {
    Scene s = load_scene(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name + ".json");
    s.camera.width = s.camera.height = kResolution;
    it = cache.emplace(name, std::move(s)).first;
  }
  return it->second;
}

// Extra single-sample parameters for experiments ("key=value,key=value"), e.g.
//   SINGLE_SAMPLE_PARAMS=neighbours=false build/single_sample_bench
std::vector<std::string> single_sample_params() {
  std::vector<std::string> out;
  const char* env = std::getenv("SINGLE_SAMPLE_PARAMS");
  std::string all = env ? env : "";
  for (size_t b = 0; b < all.size();) {
    size_t e = all.find(',', b);
    if (e == std::string::npos) e = all.size();
    if (e > b) out.push_back(all.substr(b, e - b));
    b = e + 1;
  }
  return out;
}

RenderSettings settings(const std::string& method) {
  RenderSettings s;
  s.method = method;
  s.light_samples = kReferenceSpp;
  if (method == "single-sample") s.params = single_sample_params();
  return s;
}

// CPU time of the whole process (every thread), in ms: on a shared machine it moves less
// than wall time when other work competes for the cores.
double process_cpu_ms() {
  rusage u;
  getrusage(RUSAGE_SELF, &u);
  return 1e3 * (u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-3 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

void BM_Frame(benchmark::State& state, const std::string& scene_name, const std::string& method) {
  const Scene& sc = scene(scene_name);
  double cpu0 = process_cpu_ms();
  for (auto _ : state) {
    RenderResult r = render_scene(sc, settings(method));
    benchmark::DoNotOptimize(r.visibility.data());
  }
  state.counters["cpu_ms"] = (process_cpu_ms() - cpu0) / std::max<int64_t>(1, state.iterations());
}

void BM_Warm(benchmark::State& state, const std::string& scene_name, const std::string& method) {
  Renderer renderer(scene(scene_name), settings(method));
  renderer.render();  // prepare() once
  double cpu0 = process_cpu_ms();
  for (auto _ : state) {
    RenderResult r = renderer.render();
    benchmark::DoNotOptimize(r.visibility.data());
  }
  state.counters["cpu_ms"] = (process_cpu_ms() - cpu0) / std::max<int64_t>(1, state.iterations());
}

void BM_Shadow(benchmark::State& state, const std::string& scene_name, const std::string& method) {
  const Scene& sc = scene(scene_name);
  ThreadLimit one(1);
  RayTracer tracer(sc);
  ViewSamples vs = camera_pass(sc, tracer, 0);
  auto m = create_method(method, sc, settings(method).params);
  ShadowContext ctx;
  ctx.scene = &sc;
  ctx.light = &sc.lights[0];
  ctx.tracer = &tracer;
  ctx.light_samples = kReferenceSpp;
  m->prepare(ctx);
  std::vector<float> v(vs.size());
  std::vector<Vec3f> e(vs.size());
  ShadowOutput out{v, e};
  for (auto _ : state) m->evaluate(ctx, vs, out);
  m->stats() = MethodStats{};
  m->evaluate(ctx, vs, out);
  for (const auto& [key, value] : m->stats().extra.items())
    if (value.is_number()) state.counters[key] = value.get<double>();
}

// prepare() alone on one thread (CPU time): the per-light build.
void BM_Prepare(benchmark::State& state, const std::string& scene_name, const std::string& method) {
  const Scene& sc = scene(scene_name);
  ThreadLimit one(1);
  RayTracer tracer(sc);
  ShadowContext ctx;
  ctx.scene = &sc;
  ctx.light = &sc.lights[0];
  ctx.tracer = &tracer;
  for (auto _ : state) {
    auto m = create_method(method, sc, settings(method).params);
    m->prepare(ctx);
    benchmark::DoNotOptimize(m.get());
  }
}

// Collects the median real time of every benchmark and prints the ratios at the end.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      bool median = r.run_type == Run::RT_Aggregate && r.aggregate_name == "median";
      bool single = r.run_type == Run::RT_Iteration && r.repetitions <= 1;
      if (!median && !single) continue;
      const std::string& name = r.run_name.function_name;
      ms_[name] = r.GetAdjustedRealTime();  // in the benchmarks' unit: ms
      auto cpu = r.counters.find("cpu_ms");
      if (cpu != r.counters.end()) cpu_ms_[name] = cpu->second.value;
    }
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    std::printf("\nmedians over repetitions, %dx%d, reference at %d spp; wall ms (process CPU ms)\n", kResolution,
                kResolution, kReferenceSpp);
    std::printf("%-6s %-6s %16s %16s %18s %12s %12s\n", "kind", "scene", "hard", "single-sample", "reference",
                "single/hard", "ref/single");
    for (const char* kind : {"frame", "warm"})
      for (const char* sc : kScenes) {
        auto get = [&](const std::map<std::string, double>& m, const char* method) {
          auto it = m.find(std::string(kind) + "/" + sc + "/" + method);
          return it == m.end() ? -1.0 : it->second;
        };
        double h = get(ms_, "hard"), s = get(ms_, "single-sample"), ref = get(ms_, "reference");
        double hc = get(cpu_ms_, "hard"), scpu = get(cpu_ms_, "single-sample"), rc = get(cpu_ms_, "reference");
        if (h < 0 && s < 0) continue;
        auto cell = [](double w, double c) {
          char buf[64];
          std::snprintf(buf, sizeof buf, w < 0 ? "-" : "%.1f (%.0f)", w, c);
          return std::string(buf);
        };
        char ratio[64] = "-", ref_ratio[64] = "-";
        if (h > 0 && s > 0) std::snprintf(ratio, sizeof ratio, "%.2f (%.2f)", s / h, scpu / hc);
        if (s > 0 && ref > 0) std::snprintf(ref_ratio, sizeof ref_ratio, "%.1f (%.1f)", ref / s, rc / scpu);
        std::printf("%-6s %-6s %16s %16s %18s %12s %12s\n", kind, sc, cell(h, hc).c_str(), cell(s, scpu).c_str(),
                    cell(ref, rc).c_str(), ratio, ref_ratio);
      }
  }

 private:
  std::map<std::string, double> ms_, cpu_ms_;
};

double min_of(const std::vector<double>& v) { return v.empty() ? 0.0 : *std::min_element(v.begin(), v.end()); }

void register_all() {
  for (const char* sc : kScenes) {
    std::string name(sc);
    for (const char* m : {"hard", "single-sample"}) {
      benchmark::RegisterBenchmark(("frame/" + name + "/" + m).c_str(), BM_Frame, name, std::string(m))
          ->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(0.5)->Repetitions(5);
      benchmark::RegisterBenchmark(("warm/" + name + "/" + m).c_str(), BM_Warm, name, std::string(m))
          ->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(0.5)->Repetitions(5);
    }
    // 256 shadow rays per view sample: one frame takes seconds.
    benchmark::RegisterBenchmark(("frame/" + name + "/reference").c_str(), BM_Frame, name, std::string("reference"))
        ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1)->Repetitions(3);
    benchmark::RegisterBenchmark(("prepare/" + name + "/single-sample").c_str(), BM_Prepare, name,
                                 std::string("single-sample"))
        ->Unit(benchmark::kMillisecond)->MinTime(0.2)->Repetitions(5)->ComputeStatistics("min", min_of);
    for (const char* m : {"hard", "single-sample"})
      benchmark::RegisterBenchmark(("shadow/" + name + "/" + m).c_str(), BM_Shadow, name, std::string(m))
          ->Unit(benchmark::kMillisecond)->MinTime(0.2)->Repetitions(5)->ComputeStatistics("min", min_of);
  }
}

}  // namespace
}  // namespace penumbra

int main(int argc, char** argv) {
  penumbra::register_all();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  penumbra::RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
