// One whole frame at 512x512 on bunny as an interactive client sees it: the camera pass, the
// method's evaluate, the composition with the closed-form irradiance and the resolve into
// pixels (Renderer::render with the method already prepared, so light-space structures are
// not rebuilt: the camera moves every frame, the light does not). `penumbra bench --suite perf`
// times the other case, the first frame of a fresh renderer (prepare included). Issue 14's 60 fps target is a whole
// frame under 16 ms for the cheap methods; BM_CameraPass isolates the part all of them share.
// BM_LightMoveFrame times the viewer's light drag: a moving light, prepare included.
//
//   build/frame_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <map>
#include <memory>

#include "bench_fixture.h"
#include "penumbra/render/renderer.h"

namespace penumbra {
namespace {

constexpr int kResolution = 512;

void BM_CameraPass(benchmark::State& state, const std::string& name) {
  bench::SceneFixture& f = bench::scene_fixture(name, kResolution);
  size_t samples = 0;
  CameraPass pass;  // buffers kept between frames, as the Renderer keeps them
  ViewSamples vs;
  for (auto _ : state) {
    pass.run(f.scene, *f.tracer, 0, vs);
    samples += vs.size();
    benchmark::DoNotOptimize(vs.samples.data());
  }
  state.counters["samples_per_s"] = benchmark::Counter(static_cast<double>(samples), benchmark::Counter::kIsRate);
}

void BM_Frame(benchmark::State& state, const std::string& name, const std::string& method) {
  bench::SceneFixture& f = bench::scene_fixture(name, kResolution);
  RenderSettings settings;
  settings.method = method;
  Renderer renderer(f.scene, settings);
  renderer.render();  // prepare once
  // The camera moves every frame (two eye positions 1% of the eye distance apart), so
  // nothing that depends on the view (e.g. a shadow map fitted to the receivers) is reused.
  Camera cameras[2] = {f.scene.camera, f.scene.camera};
  cameras[1].eye = cameras[1].eye + (cameras[1].eye - cameras[1].target) * 0.01f;
  double camera = 0, compose = 0;
  int frame = 0;
  for (auto _ : state) {
    renderer.set_camera(cameras[++frame % 2]);
    RenderResult r = renderer.render();
    camera += r.camera_pass_ms;
    for (const auto& [phase, ms] : r.stats.phases_ms)
      if (phase == "compose") compose += ms;
  }
  state.counters["camera_ms"] = benchmark::Counter(camera / state.iterations());
  state.counters["compose_ms"] = benchmark::Counter(compose / state.iterations());
}

// The other interactive case, the viewer's light drag (docs/viewer.md): the light moves every
// frame (two centres 2% of the scene's size apart), so each frame rebuilds the method's
// light-space structures (Renderer::set_lights, prepare) and then evaluates; the Embree scene
// is kept. What `penumbra view` previews with when a light moves.
void BM_LightMoveFrame(benchmark::State& state, const std::string& name, const std::string& method) {
  bench::SceneFixture& f = bench::scene_fixture(name, kResolution);
  RenderSettings settings;
  settings.method = method;
  Renderer renderer(f.scene, settings);
  renderer.render();
  std::vector<AreaLight> lights[2] = {f.scene.lights, f.scene.lights};
  const Bounds3f b = f.scene.bounds();
  for (AreaLight& l : lights[1]) l.center = l.center + Vec3f(0.02f * length(b.hi - b.lo), 0, 0);
  int frame = 0;
  for (auto _ : state) {
    renderer.set_lights(lights[++frame % 2]);
    benchmark::DoNotOptimize(renderer.render().color.data().data());
  }
}

void register_all() {
  benchmark::RegisterBenchmark("camera_pass/bunny", BM_CameraPass, std::string("bunny"))
      ->Unit(benchmark::kMillisecond)->UseRealTime();
  for (const char* method : {"hard", "shadow-map", "pcss", "single-sample", "occlusion-textures", "lam"})
    benchmark::RegisterBenchmark((std::string("frame/bunny/") + method).c_str(), BM_Frame, std::string("bunny"),
                                 std::string(method))
        ->Unit(benchmark::kMillisecond)->UseRealTime();
  for (const char* method : {"hard", "shadow-map", "pcss", "occlusion-textures"})
    benchmark::RegisterBenchmark((std::string("light_move_frame/bunny/") + method).c_str(), BM_LightMoveFrame,
                                 std::string("bunny"), std::string(method))
        ->Unit(benchmark::kMillisecond)->UseRealTime();
}

}  // namespace
}  // namespace penumbra

int main(int argc, char** argv) { return penumbra::bench::run_benchmarks(argc, argv, penumbra::register_all); }
