// Each method's memory estimate (MethodInfo::estimate_memory, issue 17 "Limits") against what
// the method really allocates, and how the estimates grow with their settings.
//
// How the heap is measured: this test binary replaces the global operator new and delete
// (every std::vector, make_unique and std::function of the methods goes through them) and,
// while a HeapWindow is open, counts the bytes in use: their current sum and its peak. The
// peak catches what a before/after comparison (mallinfo2) cannot: the transient buffers of
// prepare/evaluate (lam's layer slots while building, mtsm's per-texel vectors, the
// receivers a fit collects), which the estimates include. Embree's own allocations belong
// to the RayTracer, built before the window opens. AddressSanitizer replaces the allocator
// itself, so under it the counting is compiled out and the measuring test skips.
#include <gtest/gtest.h>
#include <malloc.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <new>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "penumbra/core/parallel.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/testing/memory_cases.h"
#include "penumbra/testing/test_scenes.h"
#include "penumbra/trace/ray_tracer.h"

// AddressSanitizer and ThreadSanitizer bring their own operator new: no counting then.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define PENUMBRA_SANITIZER_ALLOCATOR 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define PENUMBRA_SANITIZER_ALLOCATOR 1
#endif
#endif
#ifndef PENUMBRA_SANITIZER_ALLOCATOR
#define PENUMBRA_SANITIZER_ALLOCATOR 0
#endif

namespace {

std::atomic<bool> g_counting{false};
std::atomic<int64_t> g_current{0}, g_peak{0};

#if !PENUMBRA_SANITIZER_ALLOCATOR
void count_alloc(void* p) {
  if (!p || !g_counting.load(std::memory_order_relaxed)) return;
  const int64_t now = g_current.fetch_add(static_cast<int64_t>(malloc_usable_size(p)), std::memory_order_relaxed) +
                      static_cast<int64_t>(malloc_usable_size(p));
  int64_t peak = g_peak.load(std::memory_order_relaxed);
  while (now > peak && !g_peak.compare_exchange_weak(peak, now, std::memory_order_relaxed)) {
  }
}
void count_free(void* p) {
  if (p && g_counting.load(std::memory_order_relaxed))
    g_current.fetch_sub(static_cast<int64_t>(malloc_usable_size(p)), std::memory_order_relaxed);
}
void* counted_alloc(std::size_t n) {
  void* p = std::malloc(n ? n : 1);
  count_alloc(p);
  return p;
}
void* counted_aligned_alloc(std::size_t n, std::align_val_t a) {
  const std::size_t align = static_cast<std::size_t>(a);
  void* p = std::aligned_alloc(align, (std::max<std::size_t>(n, 1) + align - 1) / align * align);
  count_alloc(p);
  return p;
}
void counted_free(void* p) {
  count_free(p);
  std::free(p);
}
#endif

}  // namespace

#if !PENUMBRA_SANITIZER_ALLOCATOR
void* operator new(std::size_t n) {
  if (void* p = counted_alloc(n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) { return operator new(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept { return counted_alloc(n); }
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept { return counted_alloc(n); }
void* operator new(std::size_t n, std::align_val_t a) {
  if (void* p = counted_aligned_alloc(n, a)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n, std::align_val_t a) { return operator new(n, a); }
void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return counted_aligned_alloc(n, a);
}
void* operator new[](std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return counted_aligned_alloc(n, a);
}
void operator delete(void* p) noexcept { counted_free(p); }
void operator delete[](void* p) noexcept { counted_free(p); }
void operator delete(void* p, std::size_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::size_t) noexcept { counted_free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { counted_free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { counted_free(p); }
void operator delete(void* p, std::align_val_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { counted_free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { counted_free(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { counted_free(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { counted_free(p); }
#endif

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// Bytes in use through operator new since the window opened: now and at most. Frees of
// blocks allocated before count too (the heap in use went down).
class HeapWindow {
 public:
  HeapWindow() {
    g_current = 0;
    g_peak = 0;
    g_counting = true;
  }
  ~HeapWindow() { g_counting = false; }
  int64_t current() const { return g_current.load(); }
  int64_t peak() const { return g_peak.load(); }
};

// A box and a quad (opaque: mtsm's texels then hold at most resets + 1 layers, as its
// estimate assumes) over the ground under a rect light; every camera ray hits the ground,
// and the light-space views, fitted to a square of ground, are about square.
Scene maps_scene(int res = 32) {
  std::vector<SceneObject> occluders;
  occluders.push_back(testing::object(testing::box({-0.6f, 0.3f, -0.4f}, {0.1f, 0.8f, 0.3f})));
  occluders.push_back(testing::object(testing::quad_y(1.1f, 0.2f, 1.0f, -0.6f, 0.5f)));
  return testing::ground_scene(std::move(occluders), testing::rect_light_down({0, 2, 0}, 1.2f, 0.8f), res);
}

// The same with a finely tessellated, gently bumpy sheet of 2 x 150^2 triangles as the
// occluder: for single-sample, whose memory is all per triangle.
Scene triangles_scene() {
  constexpr int kCells = 150;
  TriangleMesh m;
  for (int j = 0; j <= kCells; ++j)
    for (int i = 0; i <= kCells; ++i) {
      const float x = -0.8f + 1.6f * i / kCells, z = -0.8f + 1.6f * j / kCells;
      m.positions.push_back({x, 0.8f + 0.05f * std::sin(7 * x) * std::cos(5 * z), z});
    }
  for (int j = 0; j < kCells; ++j)
    for (int i = 0; i < kCells; ++i) {
      const uint32_t a = j * (kCells + 1) + i, b = a + 1, c = a + kCells + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
    }
  std::vector<SceneObject> occluders;
  occluders.push_back(testing::object(std::move(m)));
  return testing::ground_scene(std::move(occluders), testing::rect_light_down({0, 2, 0}, 1.2f, 0.8f), 32);
}

using MeasureCase = testing::MemoryMeasureCase;

// Every method's cases, declared beside it (testing/memory_cases.h), by method name.
std::vector<MeasureCase> measure_cases() {
  std::vector<MeasureCase> cases = testing::memory_cases().measure;
  std::stable_sort(cases.begin(), cases.end(),
                   [](const MeasureCase& a, const MeasureCase& b) { return a.method < b.method; });
  return cases;
}

void PrintTo(const MeasureCase& c, std::ostream* os) { *os << c.method; }

// Small allocations no estimate counts (statistics, JSON extras, thread-local bookkeeping).
constexpr int64_t kSlack = 256 << 10;
// Estimates are upper bounds (resolution^2 for fitted windows, worst-case layers and vector
// growth); this far above the measured peak they would refuse renders that fit.
constexpr int64_t kFactor = 4;

class MemoryEstimateMatchesHeap : public ::testing::TestWithParam<MeasureCase> {};

TEST_P(MemoryEstimateMatchesHeap, WithinAFactorOfTheMeasuredPeak) {
#if PENUMBRA_SANITIZER_ALLOCATOR
  GTEST_SKIP() << "A sanitizer replaces the allocator: operator new is not counted in this build";
#endif
  const MeasureCase& c = GetParam();
  const MethodInfo& info = MethodRegistry::get(c.method);
  ASSERT_TRUE(info.estimate_memory) << c.method << " has no memory estimate";
  ThreadLimit limit(2);
  const Scene scene = c.many_triangles ? triangles_scene() : maps_scene(c.image);
  const RayTracer tracer(scene);
  const ViewSamples vs = camera_pass(scene, tracer, 1);
  std::vector<float> vis(vs.size(), 1.0f);
  std::vector<Vec3f> irr(vs.size());
  ShadowOutput out{std::span<float>(vis), std::span<Vec3f>(irr)};
  const ParamSet params = resolve_method_params(c.method, scene, c.params);

  MemoryQuery q;
  q.view_samples = static_cast<uint64_t>(scene.camera.width) * scene.camera.height;
  q.light_samples = c.light_samples;
  q.triangles = scene.triangle_count();
  q.threads = max_threads();
  q.light = &scene.lights[0];
  const MemoryEstimate estimate = info.estimate_memory(params, q);

  ShadowContext ctx;
  ctx.scene = &scene;
  ctx.light = &scene.lights[0];
  ctx.tracer = &tracer;
  ctx.seed = 1;
  ctx.light_samples = c.light_samples;
  int64_t peak = 0, held = 0;
  {
    HeapWindow window;
    {
      std::unique_ptr<ShadowMethod> method = info.create(params);
      method->prepare(ctx);
      method->evaluate(ctx, vs, out);
      held = window.current();
    }
    peak = window.peak();
  }
  const int64_t e = static_cast<int64_t>(estimate.bytes);
  std::printf("[ %-18s ] estimate %8.1f MiB (%s), measured peak %8.1f MiB, held after evaluate %8.1f MiB\n",
              c.method.c_str(), e / 1048576.0, estimate.setting.c_str(), peak / 1048576.0, held / 1048576.0);
  // The maps must dominate, or the comparison says little about them.
  EXPECT_GT(peak, 16 * kSlack) << "make the case's maps larger";
  EXPECT_LE(peak, e + kSlack) << "the method allocates more than its estimate: a structure is not counted";
  EXPECT_LE(e, kFactor * peak + kSlack) << "the estimate is far above what the method allocates";
}

INSTANTIATE_TEST_SUITE_P(EveryMethod, MemoryEstimateMatchesHeap, ::testing::ValuesIn(measure_cases()),
                         [](const ::testing::TestParamInfo<MeasureCase>& i) {
                           std::string name;
                           for (char ch : i.param.method)
                             name += std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
                           return i.param.many_triangles ? name + "_many_triangles" : name;
                         });

TEST(MemoryEstimate, EveryMethodButHardHasOneAndIsMeasured) {
  std::vector<std::string> measured;
  for (const MeasureCase& c : measure_cases()) measured.push_back(c.method);
  for (const MethodInfo* info : MethodRegistry::all()) {
    SCOPED_TRACE(info->name);
    if (info->name == "hard") {
      EXPECT_FALSE(info->estimate_memory) << "hard holds nothing that grows with a setting";
      continue;
    }
    EXPECT_TRUE(info->estimate_memory);
    EXPECT_NE(std::find(measured.begin(), measured.end(), info->name), measured.end())
        << "register a measuring case for it beside its tests (testing/memory_cases.h)";
  }
}

// The estimate at these parameter overrides and query.
MemoryEstimate estimate_at(const std::string& method, const std::vector<std::string>& params, const MemoryQuery& q) {
  const Scene scene = maps_scene();
  return MethodRegistry::get(method).estimate_memory(resolve_method_params(method, scene, params), q);
}

MemoryQuery base_query(const Scene& scene) {
  MemoryQuery q;
  q.view_samples = 640 * 480;
  q.light_samples = 16;
  q.triangles = 10000;
  q.threads = 4;
  q.light = &scene.lights[0];
  return q;
}

TEST(MemoryEstimate, GrowsWithEverySettingThatDrivesIt) {
  // What each method's estimate must grow with: its size parameters (doubled from their
  // default, or from half the maximum when the default is above that), and --spp ("--spp")
  // or the scene's triangles ("triangles").
  const std::map<std::string, std::vector<std::string>>& drivers = testing::memory_cases().drivers;
  const Scene scene = maps_scene();
  for (const MethodInfo* info : MethodRegistry::all()) {
    if (!info->estimate_memory) continue;
    SCOPED_TRACE(info->name);
    auto it = drivers.find(info->name);
    ASSERT_NE(it, drivers.end()) << "register what this method's estimate grows with (testing/memory_cases.h)";
    const MemoryQuery q = base_query(scene);
    const uint64_t base = estimate_at(info->name, {}, q).bytes;
    for (const std::string& driver : it->second) {
      SCOPED_TRACE(driver);
      uint64_t grown = 0;
      if (driver == "--spp") {
        MemoryQuery more = q;
        more.light_samples = 4 * q.light_samples;
        grown = estimate_at(info->name, {}, more).bytes;
      } else if (driver == "triangles") {
        MemoryQuery more = q;
        more.triangles = 10 * q.triangles;
        grown = estimate_at(info->name, {}, more).bytes;
      } else {
        const auto spec = std::find_if(info->params.begin(), info->params.end(),
                                       [&](const ParamSpec& p) { return p.name == driver; });
        ASSERT_NE(spec, info->params.end());
        const int def = spec->default_value.get<int>(), max = static_cast<int>(spec->max);
        // leaf_size: fewer, larger leaves need fewer nodes; the estimate grows as it shrinks.
        const bool down = driver == "leaf_size";
        const int from = down ? def : std::min(def, max / 2), to = down ? std::max(1, def / 2) : 2 * from;
        const uint64_t a = estimate_at(info->name, {fmt::format("{}={}", driver, from)}, q).bytes;
        grown = estimate_at(info->name, {fmt::format("{}={}", driver, to)}, q).bytes;
        EXPECT_GT(grown, a) << driver << " " << from << " -> " << to;
        continue;
      }
      EXPECT_GT(grown, base);
    }
    // Never less for more view samples.
    MemoryQuery more = q;
    more.view_samples *= 4;
    EXPECT_GE(estimate_at(info->name, {}, more).bytes, base);
  }
}

TEST(MemoryEstimate, NamesTheSettingThatDrivesIt) {
  const Scene scene = maps_scene();
  MemoryQuery q = base_query(scene);
  q.triangles = 1000;
  // At the top of a size parameter's range, that parameter is what to lower.
  EXPECT_EQ(estimate_at("occlusion-textures", {"resolution=4096", "slices=32"}, q).setting, "resolution");
  EXPECT_EQ(estimate_at("mlsm", {"resolution=16384"}, q).setting, "resolution");
  MemoryQuery many_samples = q;
  many_samples.light_samples = 1024;
  EXPECT_EQ(estimate_at("afsm", {"lut_resolution=1024"}, many_samples).setting, "lut_resolution");
  EXPECT_EQ(estimate_at("afsm", {"resolution=64", "lut_resolution=4"}, many_samples).setting, "--spp");
  many_samples.light_samples = 1 << 20;
  EXPECT_EQ(estimate_at("reference", {}, many_samples).setting, "--spp");
  MemoryQuery many_triangles = q;
  many_triangles.triangles = 10000000;
  EXPECT_EQ(estimate_at("single-sample", {}, many_triangles).setting, kTrianglesSetting);
  // And a render refused for it says so, naming the parameter as -p METHOD.NAME.
  Scene tiny = maps_scene(8);
  RenderSettings settings;
  settings.method = "occlusion-textures";
  settings.params = {"resolution=4096", "slices=32"};
  settings.memory_limit = 64 << 20;
  try {
    check_render_memory(tiny, settings);
    ADD_FAILURE() << "not refused";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("lower -p occlusion-textures.resolution or raise --memory-limit"),
              std::string::npos)
        << e.what();
  }
  settings.method = "single-sample";
  settings.params = {};
  settings.memory_limit = 1 << 10;
  try {
    check_render_memory(triangles_scene(), settings);
    ADD_FAILURE() << "not refused";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("lower the scene's triangle count or raise"), std::string::npos) << e.what();
  }
}

// A sphere light inside the scene is drawn as one light per face of a cube (drawn_lights): the
// estimate counts each face's method instance, and the copy of the view samples a face draws.
TEST(MemoryEstimate, ASplitSphereCountsEveryFacesInstance) {
  const Scene bulb = testing::bulb_in_a_room_scene(32);
  RenderSettings settings;
  settings.method = "shadow-map";
  const std::vector<AreaLight> drawn = drawn_lights(bulb, settings.method, bulb.lights);
  ASSERT_EQ(drawn.size(), 6u);
  const RenderMemoryEstimate split = estimate_render_memory(bulb, settings);
  // The same room and bulb drawn whole: reference samples each point's own silhouette.
  settings.method = "reference";
  EXPECT_EQ(drawn_lights(bulb, settings.method, bulb.lights).size(), 1u);
  settings.method = "shadow-map";
  Scene whole = bulb;
  whole.lights[0].shape = LightShape::Disk;  // a disk is never split: the same one instance's maps
  const RenderMemoryEstimate one = estimate_render_memory(whole, settings);
  EXPECT_EQ(split.method_bytes, 6 * one.method_bytes);
  EXPECT_EQ(split.view_bytes, one.view_bytes + 32 * 32 * (sizeof(ViewSample) + 4));
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
