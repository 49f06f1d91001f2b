// Raster layer throughput: triangles and fragments per second for every mode on the Stanford
// bunny (69,666 triangles) and on a plant-like mesh of many small quads, and the time to
// render a 1024^2 depth map against Embree's BVH build (rtcCommitScene) for the same
// triangles. Results and the command line: docs/raster.md.
#include <benchmark/benchmark.h>

#include <embree3/rtcore.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "penumbra/raster/conservative.h"
#include "penumbra/raster/minmax_pyramid.h"
#include "penumbra/raster/rasterizer.h"
#include "penumbra/raster/test_meshes.h"

namespace penumbra {
namespace {

enum class Mesh { Bunny, Plant };

const std::vector<RasterTriangle>& mesh(Mesh m) {
  static std::map<Mesh, std::vector<RasterTriangle>> cache;
  auto it = cache.find(m);
  if (it != cache.end()) return it->second;
  std::vector<RasterTriangle> tris = m == Mesh::Bunny ? test_meshes::read_obj(test_meshes::kBunnyPath)
                                                      : test_meshes::plant(40000);  // 80k triangles
  return cache.emplace(m, std::move(tris)).first->second;
}

// The light above and in front of the object, frustum fitted to it (the way a shadow-map
// method sets up its light view).
LightView view_of(Mesh m, int resolution) {
  Bounds3f b = test_meshes::bounds_of(mesh(m));
  Vec3f eye = b.center() + Vec3f(0.4f, 1.5f, 0.6f) * length(b.diagonal());
  return LightView::frustum_fitted(eye, b.center() - eye, {0, 0, -1}, b, resolution, resolution, 1e-3f);
}

bool skip_if_missing(benchmark::State& state, Mesh m) {
  if (mesh(m).empty()) {
    state.SkipWithError("mesh not available (bunny: install glmark2-data)");
    return true;
  }
  return false;
}

void report(benchmark::State& state, const RasterStats& s, size_t triangles, size_t fragments) {
  using benchmark::Counter;
  state.counters["tris/s"] = Counter(double(triangles) * state.iterations(), Counter::kIsRate);
  state.counters["frags/s"] = Counter(double(fragments) * state.iterations(), Counter::kIsRate);
  state.counters["frags"] = double(fragments);
  state.counters["setup_ms"] = s.setup_ms;  // of the last iteration
  state.counters["raster_ms"] = s.raster_ms;
}

void BM_DepthMap(benchmark::State& state, Mesh m) {
  if (skip_if_missing(state, m)) return;
  const auto& tris = mesh(m);
  LightView view = view_of(m, int(state.range(0)));
  Rasterizer raster;
  DepthMap map;
  for (auto _ : state) {
    raster.depth_map(tris, view, {}, &map);
    benchmark::DoNotOptimize(map.z.data());
  }
  report(state, raster.stats(), tris.size(), raster.stats().fragments);
}

void BM_LayeredDepthMap(benchmark::State& state, Mesh m) {
  if (skip_if_missing(state, m)) return;
  const auto& tris = mesh(m);
  LightView view = view_of(m, int(state.range(0)));
  Rasterizer raster;
  LayeredDepthMap map;
  LayerOptions options;
  options.layers = 5;
  for (auto _ : state) {
    raster.layered_depth_map(tris, view, options, &map);
    benchmark::DoNotOptimize(map.samples.data());
  }
  report(state, raster.stats(), tris.size(), raster.stats().fragments);
}

void BM_FragmentLists(benchmark::State& state, Mesh m) {
  if (skip_if_missing(state, m)) return;
  const auto& tris = mesh(m);
  LightView view = view_of(m, int(state.range(0)));
  Rasterizer raster;
  FragmentLists lists;
  for (auto _ : state) {
    raster.fragment_lists(tris, view, {}, &lists);
    benchmark::DoNotOptimize(lists.fragments.data());
  }
  report(state, raster.stats(), tris.size(), raster.stats().fragments);
}

void BM_Conservative(benchmark::State& state, Mesh m) {
  if (skip_if_missing(state, m)) return;
  const auto& tris = mesh(m);
  LightView view = view_of(m, int(state.range(0)));
  ConservativeRasterizer raster;
  std::vector<uint32_t> hits(size_t(view.width()) * view.height());
  size_t covered = 0;
  for (auto _ : state) {
    std::fill(hits.begin(), hits.end(), 0u);
    // Per-texel writes without atomics: the callback contract (one thread per texel).
    raster.triangles(tris, view, {}, [&](int x, int y, uint32_t) { ++hits[size_t(y) * view.width() + x]; });
    covered = 0;
    for (uint32_t h : hits) covered += h;
  }
  RasterStats none;
  report(state, none, tris.size(), covered);
}

void BM_Pyramid(benchmark::State& state, Mesh m) {
  if (skip_if_missing(state, m)) return;
  LightView view = view_of(m, int(state.range(0)));
  LayerOptions options;
  LayeredDepthMap map = render_layered_depth_map(mesh(m), view, options);
  for (auto _ : state) {
    MinMaxPyramid pyr(map);
    benchmark::DoNotOptimize(pyr.root());
  }
  state.counters["texels/s"] = benchmark::Counter(double(map.counts.size()) * state.iterations(), benchmark::Counter::kIsRate);
}

// rtcCommitScene alone (buffers filled outside the timed part): Embree's BVH build for the
// same triangles, the fixed cost a ray-traced method pays where a map method rasterizes.
void BM_EmbreeBuild(benchmark::State& state, Mesh m) {
  if (skip_if_missing(state, m)) return;
  const auto& tris = mesh(m);
  RTCDevice device = rtcNewDevice(nullptr);
  for (auto _ : state) {
    RTCScene scene = rtcNewScene(device);
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), 3 * tris.size()));
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                3 * sizeof(unsigned), tris.size()));
    for (size_t i = 0; i < tris.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        v[9 * i + 3 * k + 0] = tris[i].p[k].x;
        v[9 * i + 3 * k + 1] = tris[i].p[k].y;
        v[9 * i + 3 * k + 2] = tris[i].p[k].z;
        idx[3 * i + k] = unsigned(3 * i + k);
      }
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    auto t0 = std::chrono::steady_clock::now();
    rtcCommitScene(scene);
    auto t1 = std::chrono::steady_clock::now();
    state.SetIterationTime(std::chrono::duration<double>(t1 - t0).count());
    rtcReleaseScene(scene);
  }
  rtcReleaseDevice(device);
  state.counters["tris/s"] = benchmark::Counter(double(tris.size()) * state.iterations(), benchmark::Counter::kIsRate);
}

// The minimum over repetitions beside Google Benchmark's mean/median/stddev: the machine is
// shared, and the minimum is the least disturbed run.
double min_of(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

#define PENUMBRA_RASTER_BENCH(fn, m, ...)                                                     \
  BENCHMARK_CAPTURE(fn, m, Mesh::m)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", min_of) \
      ->UseRealTime()->__VA_ARGS__

PENUMBRA_RASTER_BENCH(BM_DepthMap, Bunny, Arg(512)->Arg(1024)->Arg(2048));
PENUMBRA_RASTER_BENCH(BM_DepthMap, Plant, Arg(512)->Arg(1024)->Arg(2048));
PENUMBRA_RASTER_BENCH(BM_LayeredDepthMap, Bunny, Arg(512)->Arg(1024));
PENUMBRA_RASTER_BENCH(BM_LayeredDepthMap, Plant, Arg(512)->Arg(1024));
PENUMBRA_RASTER_BENCH(BM_FragmentLists, Bunny, Arg(512)->Arg(1024));
PENUMBRA_RASTER_BENCH(BM_FragmentLists, Plant, Arg(512)->Arg(1024));
PENUMBRA_RASTER_BENCH(BM_Conservative, Bunny, Arg(512)->Arg(1024));
PENUMBRA_RASTER_BENCH(BM_Conservative, Plant, Arg(512)->Arg(1024));
PENUMBRA_RASTER_BENCH(BM_Pyramid, Bunny, Arg(512)->Arg(1024));
BENCHMARK_CAPTURE(BM_EmbreeBuild, Bunny, Mesh::Bunny)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", min_of)->UseManualTime();
BENCHMARK_CAPTURE(BM_EmbreeBuild, Plant, Mesh::Plant)->Unit(benchmark::kMillisecond)->ComputeStatistics("min", min_of)->UseManualTime();

}  // namespace
}  // namespace penumbra

BENCHMARK_MAIN();
