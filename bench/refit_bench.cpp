// Moving objects in the Embree scene (issue 18 part 3, docs/animation.md "Objects that
// move"): refitting the animated objects' BVHs in RayTracer's two-level scene against
// building the scene afresh, and what the two-level scene costs every shadow ray against the
// single-level one, on the animated scenes whose objects move.
//
//   build/refit_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <vector>

#include <fmt/format.h>

#include "bench_fixture.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/scene.h"

namespace penumbra {
namespace {

constexpr int kFrames = 8;
constexpr int kResolution = 128;
constexpr int kSpp = 16;

struct Fixture {
  std::vector<Scene> frames;      // frames 0 .. kFrames - 1 of the animation
  std::vector<uint32_t> movable;  // the objects the tracks move
  std::vector<ShadowRay> rays;    // the reference's shadow rays of frame 0's view samples
};

Fixture& fixture(const std::string& name) {
  static std::map<std::string, std::unique_ptr<Fixture>> cache;
  auto& f = cache[name];
  if (!f) {
    f = std::make_unique<Fixture>();
    if (name == "bunny-turn") {
      // The Stanford bunny (69,666 triangles) turning 7.5 degrees a frame on the ground of
      // scenes/bunny.json: a large mesh moving, where furball-spin's is small.
      Scene base = load_scene(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/bunny.json");
      base.camera.width = base.camera.height = kResolution;
      base.camera.samples_per_pixel = 1;
      uint32_t largest = 0;
      for (uint32_t o = 0; o < base.objects.size(); ++o)
        if (base.objects[o].mesh.triangle_count() > base.objects[largest].mesh.triangle_count()) largest = o;
      f->movable = {largest};
      for (int k = 0; k < kFrames; ++k) {
        Scene s = base;
        ObjectTransform t;
        t.rotate = {0, 7.5f * k, 0};
        place_object(s.objects[largest], t);
        f->frames.push_back(std::move(s));
      }
    } else {
      Scene base = load_scene(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name + ".json");
      base.camera.width = base.camera.height = kResolution;
      base.camera.samples_per_pixel = 1;
      for (int k = 0; k < kFrames; ++k) f->frames.push_back(scene_at_frame(base, k));
      f->movable = base.animation->movable_objects();
    }
    const RayTracer tracer(f->frames[0]);
    const ViewSamples vs = camera_pass(f->frames[0], tracer, 0);
    const AreaLight& light = f->frames[0].lights[0];
    for (size_t k = 0; k < vs.size(); ++k) {
      Rng rng(0, 1, k);
      const ViewSample& s = vs.samples[k];
      for (int i = 0; i < kSpp; ++i) {
        AreaLight::DirectionSample ds;
        if (light.sample_direction(s.p, stratified_sample(i, kSpp, rng.next_2d()), &ds))
          f->rays.push_back(shadow_ray_to(s.p, s.ng, s.p + ds.dir * ds.dist));
      }
    }
  }
  return *f;
}

// A new frame's Embree scene built from nothing (what a moved object cost before the refit).
void BM_Rebuild(benchmark::State& state, const std::string& name) {
  Fixture& f = fixture(name);
  int k = 0;
  for (auto _ : state) {
    RayTracer tracer(f.frames[++k % kFrames]);
    benchmark::DoNotOptimize(tracer.triangle_count());
  }
}

// The same frames, the animated objects refit in the two-level scene.
void BM_Refit(benchmark::State& state, const std::string& name) {
  Fixture& f = fixture(name);
  RayTracer tracer(f.frames[0], f.movable);
  int k = 0;
  for (auto _ : state) tracer.update_objects(f.frames[++k % kFrames], f.movable);
}

// Frame 0's shadow rays through the single-level scene (static) or the two-level one.
void BM_ShadowRays(benchmark::State& state, const std::string& name, bool two_level) {
  Fixture& f = fixture(name);
  const auto tracer = two_level ? std::make_unique<RayTracer>(f.frames[0], f.movable)
                                : std::make_unique<RayTracer>(f.frames[0]);
  std::vector<float> out(f.rays.size());
  for (auto _ : state) {
    parallel_for(f.rays.size(), 4096, [&](size_t b, size_t e) {
      tracer->transmittance(std::span<const ShadowRay>(f.rays).subspan(b, e - b), std::span<float>(out).subspan(b, e - b));
    });
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * f.rays.size()));
}

void register_all() {
  for (const char* name : {"furball-spin", "bunny-turn"}) {
    benchmark::RegisterBenchmark(fmt::format("Rebuild/{}", name).c_str(), BM_Rebuild, name)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(fmt::format("Refit/{}", name).c_str(), BM_Refit, name)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(fmt::format("ShadowRays/single-level/{}", name).c_str(), BM_ShadowRays, name, false)
        ->Unit(benchmark::kMillisecond)->UseRealTime();
    benchmark::RegisterBenchmark(fmt::format("ShadowRays/two-level/{}", name).c_str(), BM_ShadowRays, name, true)
        ->Unit(benchmark::kMillisecond)->UseRealTime();
  }
}

}  // namespace
}  // namespace penumbra

int main(int argc, char** argv) { return penumbra::bench::run_benchmarks(argc, argv, penumbra::register_all); }
