// Coherence-based ray tracing of depth images (agrawala2000 §5, Figure 10 right): the time
// to shade every view sample of a frame on the bunny and the plant at 64, 256 and 1024 light
// samples, side by side in one run:
//   reference        `reference` on Embree (stratified solid-angle samples, every ray traced)
//   none             coherent-rt, hierarchical depth-image tracing with no acceleration of
//                    §5.1.1-5.1.2 and no coherence sampling (the paper's "no acceleration")
//   accel            + min/max clipping, connectedness, clear miss, occlusion intervals, ranking
//   accel+coherence  + coherence-based light sampling (§5.2): the method's defaults
//   geometry+coherence  the same sampler driving Embree shadow rays (tracer=geometry)
// Each case is ShadowMethod::evaluate over the frame's view samples (prepare, the reference
// images, is reported as the counter prepare_ms); counters: rays per point, speedup over
// `reference` and over `none` (both measured earlier in the same run).
//
//   cmake --build build --target coherent_rt_bench -j2
//   build/coherent_rt_bench                                   # 256^2 frames
//   build/coherent_rt_bench --benchmark_filter='plant/256'    # one scene and sample count
//
// "Time" is wall-clock time; "CPU" is the CPU time of the whole process (all threads).
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <map>
#include <memory>

#include "bench_fixture.h"
#include "penumbra/core/timer.h"
#include "penumbra/render/renderer.h"

namespace penumbra {
namespace {

int resolution() {
  const char* r = std::getenv("PENUMBRA_BENCH_RESOLUTION");
  return r ? std::atoi(r) : 256;
}

struct Variant {
  const char* name;
  const char* method;
  std::vector<std::string> params;
};

const std::vector<Variant>& variants() {
  static const std::vector<Variant> v = {
      {"reference", "reference", {}},
      {"none", "coherent-rt",
       {"minmax_clipping=false", "connectedness=false", "clear_miss=false", "occlusion_intervals=false",
        "ranking=false", "coherence=false"}},
      {"accel", "coherent-rt", {"coherence=false"}},
      {"accel+coherence", "coherent-rt", {}},
      {"geometry+coherence", "coherent-rt", {"tracer=geometry"}},
  };
  return v;
}

std::map<std::string, double>& measured_ms() {
  static std::map<std::string, double> m;
  return m;
}

bench::SceneFixture& fixture(const std::string& name) { return bench::scene_fixture(name, resolution()); }

void BM_Shade(benchmark::State& state, const std::string& scene, const Variant& variant, int spp) {
  bench::SceneFixture& f = fixture(scene);
  ShadowContext ctx;
  ctx.scene = &f.scene;
  ctx.light = &f.scene.lights[0];
  ctx.tracer = f.tracer.get();
  ctx.light_samples = spp;
  auto m = create_method(variant.method, f.scene, variant.params);
  Timer tp;
  m->prepare(ctx);
  const double prepare_ms = tp.elapsed_ms();
  std::vector<float> v(f.view_samples.size());
  std::vector<Vec3f> e(f.view_samples.size());
  ShadowOutput out{v, e};
  double ms = 0;
  for (auto _ : state) {
    m->stats() = MethodStats{};
    Timer t;
    m->evaluate(ctx, f.view_samples, out);
    ms = t.elapsed_ms();
  }
  const std::string key = scene + "/" + std::to_string(spp) + "/";
  measured_ms()[key + variant.name] = ms;
  const MethodStats& st = m->stats();
  state.counters["prepare_ms"] = prepare_ms;
  state.counters["rays_per_point"] = static_cast<double>(st.rays_traced) / std::max<size_t>(1, f.view_samples.size());
  for (const char* base : {"reference", "none"}) {
    auto it = measured_ms().find(key + base);
    if (it != measured_ms().end() && ms > 0) state.counters[std::string("speedup_vs_") + base] = it->second / ms;
  }
  if (st.extra.contains("depth_images")) {
    state.counters["maps_per_ray"] = st.extra["depth_images"]["maps_per_ray"].get<double>();
    state.counters["clear_miss"] = st.extra["depth_images"]["clear_miss_fraction"].get<double>();
  }
}

void register_all() {
  for (std::string scene : {"plant", "bunny"})
    for (int spp : {64, 256, 1024})
      for (const Variant& v : variants())
        benchmark::RegisterBenchmark(("BM_Shade/" + scene + "/" + std::to_string(spp) + "/" + v.name).c_str(),
                                     BM_Shade, scene, v, spp)
            ->Unit(benchmark::kMillisecond)
            ->MeasureProcessCPUTime()
            ->UseRealTime()
            ->Iterations(1);
}

}  // namespace
}  // namespace penumbra

int main(int argc, char** argv) { return penumbra::bench::run_benchmarks(argc, argv, penumbra::register_all); }
