// occlusion-textures (eisemann2006): time per 512^2 frame, prepare (slicing + filtering) +
// evaluate (shading), for 4, 8 and 16 slices and each pre-filter, on the bunny and the
// plant, at light sizes spanning 10x (0.25x to 2.5x the scene's 1.5 x 1.5 rect). The camera
// pass runs once per scene, outside the timed loop. Counters: the per-phase times of the
// frames (ms, wall clock), the process CPU time per frame (all threads), filtered lookups
// and texels read per view sample (and lookups whose kernel lies outside the texture or is
// cut to a strip by its border), texture memory, the centre of projection's distance d, the
// fragments of the slicing pass.
//
//   cmake --build build --target occlusion_textures_bench -j2
//   build/occlusion_textures_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//   build/occlusion_textures_bench --benchmark_filter='bunny/nbuffer/S16/'
//   build/occlusion_textures_bench --benchmark_filter=prefilter     (Fig. 2: pre-filter builds)
//   OT_THREADS=1 build/occlusion_textures_bench ...   (one thread: per-phase CPU times)
//   OT_PARAMS=thin_fix=false build/occlusion_textures_bench ...   (one more method parameter)
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <map>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "bench_fixture.h"
#include "penumbra/core/parallel.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/occlusion_textures/occlusion_textures.h"

namespace penumbra {
namespace {

constexpr int kResolution = 512;

constexpr float kLightScales[] = {0.25f, 0.5f, 1.0f, 2.5f};

bench::SceneFixture& fixture(const std::string& name) { return bench::scene_fixture(name, kResolution); }

void BM_OcclusionTextures(benchmark::State& state, const std::string& name, const std::string& prefilter,
                          int slices, float light_scale) {
  bench::SceneFixture& f = fixture(name);
  Scene scene = f.scene;  // a copy with the light scaled
  AreaLight& light = scene.lights[0];
  light.size = light.size * light_scale;
  light.radius *= light_scale;
  std::vector<std::string> params = {fmt::format("prefilter={}", prefilter), fmt::format("slices={}", slices)};
  if (const char* extra = std::getenv("OT_PARAMS")) params.push_back(extra);  // e.g. OT_PARAMS=thin_fix=false
  auto method = create_method("occlusion-textures", scene, params);
  ShadowContext ctx;
  ctx.scene = &scene;
  ctx.light = &light;
  ctx.tracer = f.tracer.get();
  std::vector<float> v(f.view_samples.size());
  std::vector<Vec3f> e(f.view_samples.size());
  ShadowOutput out{v, e};
  MethodStats sum;  // phase times and texel reads summed over frames
  uint64_t lookups = 0, outside = 0, strips = 0;
  int64_t frames = 0;
  // With OT_THREADS=1 everything runs on this thread, and its CPU time per call is the cost
  // of the work alone, however loaded the machine (the least of the frames is reported).
  const bool one_thread = std::getenv("OT_THREADS") && std::atoi(std::getenv("OT_THREADS")) == 1;
  double prepare_min = 1e300, evaluate_min = 1e300;
  const double cpu0 = bench::process_cpu_ms();
  for (auto _ : state) {
    method->stats() = MethodStats{};
    const double t0 = bench::thread_cpu_ms();
    method->prepare(ctx);
    const double t1 = bench::thread_cpu_ms();
    method->evaluate(ctx, f.view_samples, out);
    const double t2 = bench::thread_cpu_ms();
    prepare_min = std::min(prepare_min, t1 - t0);
    evaluate_min = std::min(evaluate_min, t2 - t1);
    benchmark::DoNotOptimize(v.data());
    sum.accumulate(method->stats());
    lookups += method->stats().extra.value("lookups", uint64_t{0});
    outside += method->stats().extra.value("lookups_outside", uint64_t{0});
    strips += method->stats().extra.value("lookups_strips", uint64_t{0});
    ++frames;
  }
  const double n = static_cast<double>(std::max<int64_t>(1, frames));
  state.counters["cpu_ms"] = (bench::process_cpu_ms() - cpu0) / n;
  if (one_thread) {
    state.counters["prepare_cpu_min_ms"] = prepare_min;
    state.counters["evaluate_cpu_min_ms"] = evaluate_min;
  }
  state.counters["slicing_ms"] = sum.phase("slicing") / n;
  state.counters["filtering_ms"] = sum.phase("filtering") / n;
  state.counters["shading_ms"] = sum.phase("shading") / n;
  const double samples = static_cast<double>(f.view_samples.size()) * n;
  state.counters["lookups_per_sample"] = static_cast<double>(lookups) / samples;
  state.counters["texels_per_sample"] = static_cast<double>(sum.texels_visited) / samples;
  state.counters["outside_per_sample"] = static_cast<double>(outside) / samples;
  state.counters["strips_per_sample"] = static_cast<double>(strips) / samples;
  state.counters["texture_MB"] = static_cast<double>(method->stats().memory_bytes) / (1024.0 * 1024.0);
  state.counters["d"] = method->stats().extra.value("cop_distance", 0.0);
  state.counters["fragments"] = method->stats().extra.value("slicing_fragments", 0.0);
}

// eisemann2006 Fig. 2's speed column: building each pre-filter for the 16 occlusion
// textures of the bunny (the coverage of the scene's own light), at 256^2 and 512^2.
template <class Filter>
void BM_Prefilter(benchmark::State& state, int resolution) {
  bench::SceneFixture& f = fixture("bunny");
  occlusion::Options o;
  o.resolution = resolution;
  o.prefilter = occlusion::Prefilter::Mipmap;
  occlusion::OcclusionTextures ot(o);
  MethodStats stats;
  ot.build(f.scene, f.scene.lights[0], &stats);
  const occlusion::CoverageStack stack{resolution, resolution, o.slices, ot.coverage().masks};
  Filter filter;
  double cpu_min = 1e300;
  for (auto _ : state) {
    const double t0 = bench::thread_cpu_ms();
    filter.build(stack);
    cpu_min = std::min(cpu_min, bench::thread_cpu_ms() - t0);
    benchmark::DoNotOptimize(&filter);
  }
  state.counters["texture_MB"] = static_cast<double>(filter.memory_bytes()) / (1024.0 * 1024.0);
  if (std::getenv("OT_THREADS") && std::atoi(std::getenv("OT_THREADS")) == 1) state.counters["cpu_min_ms"] = cpu_min;
}

void register_all() {
  for (int r : {256, 512}) {
    benchmark::RegisterBenchmark(fmt::format("prefilter/mipmap/{}", r).c_str(), BM_Prefilter<occlusion::MipmapFilter>, r)
        ->Unit(benchmark::kMillisecond)->UseRealTime();
    benchmark::RegisterBenchmark(fmt::format("prefilter/nbuffer/{}", r).c_str(), BM_Prefilter<occlusion::NBufferFilter>, r)
        ->Unit(benchmark::kMillisecond)->UseRealTime();
    benchmark::RegisterBenchmark(fmt::format("prefilter/sat-uint32/{}", r).c_str(),
                                 BM_Prefilter<occlusion::SatFilter<uint32_t>>, r)
        ->Unit(benchmark::kMillisecond)->UseRealTime();
    benchmark::RegisterBenchmark(fmt::format("prefilter/sat-double/{}", r).c_str(),
                                 BM_Prefilter<occlusion::SatFilter<double>>, r)
        ->Unit(benchmark::kMillisecond)->UseRealTime();
  }
  for (const char* name : {"bunny", "plant"})
    for (const char* prefilter : {"nbuffer", "sat", "mipmap"})
      for (int slices : {16, 8, 4})
        for (float scale : kLightScales)
          benchmark::RegisterBenchmark(fmt::format("ot/{}/{}/S{}/light{}x", name, prefilter, slices, scale).c_str(),
                                       BM_OcclusionTextures, std::string(name), std::string(prefilter), slices, scale)
              ->Unit(benchmark::kMillisecond)
              ->UseRealTime();
}

}  // namespace
}  // namespace penumbra

int main(int argc, char** argv) { return penumbra::bench::run_benchmarks(argc, argv, penumbra::register_all); }
