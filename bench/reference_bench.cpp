// Reference shadow rays per second on the scene suite, against a bare Embree loop that
// traces the very same rays (precomputed, no sampling, no penumbra wrapper): the ratio is
// what penumbra's sampling and batching cost on top of Embree.
//
//   build/reference_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>
#include <embree3/rtcore.h>

#include <cstring>
#include <map>
#include <memory>

#include "bench_fixture.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/sampling.h"
#include "penumbra/render/renderer.h"

namespace penumbra {
namespace {

constexpr int kSpp = 64;
constexpr int kResolution = 128;

struct Fixture {
  Scene scene;
  std::unique_ptr<RayTracer> tracer;
  ViewSamples vs;
  std::vector<ShadowRay> rays;  // the reference's rays for every view sample
};

Fixture& fixture(const std::string& name) {
  static std::map<std::string, std::unique_ptr<Fixture>> cache;
  auto& f = cache[name];
  if (!f) {
    f = std::make_unique<Fixture>();
    f->scene = load_scene(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name + ".json");
    f->scene.camera.width = f->scene.camera.height = kResolution;
    f->tracer = std::make_unique<RayTracer>(f->scene);
    f->vs = camera_pass(f->scene, *f->tracer, 0);
    const AreaLight& light = f->scene.lights[0];
    for (size_t k = 0; k < f->vs.size(); ++k) {
      Rng rng(0, 1, k);
      const ViewSample& s = f->vs.samples[k];
      for (int i = 0; i < kSpp; ++i) {
        AreaLight::DirectionSample ds;
        if (light.sample_direction(s.p, stratified_sample(i, kSpp, rng.next_2d()), &ds))
          f->rays.push_back(shadow_ray_to(s.p, s.ng, s.p + ds.dir * ds.dist));
      }
    }
  }
  return *f;
}

void BM_ReferenceMethod(benchmark::State& state, const std::string& name) {
  Fixture& f = fixture(name);
  auto method = create_method("reference", f.scene, {});
  ShadowContext ctx;
  ctx.scene = &f.scene;
  ctx.light = &f.scene.lights[0];
  ctx.tracer = f.tracer.get();
  ctx.light_samples = kSpp;
  std::vector<float> v(f.vs.size());
  std::vector<Vec3f> e(f.vs.size());
  ShadowOutput out{v, e};
  uint64_t rays = 0;
  for (auto _ : state) {
    method->stats() = MethodStats{};
    method->evaluate(ctx, f.vs, out);
    rays += method->stats().rays_traced;
  }
  state.counters["rays_per_s"] = benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsRate);
}

// What any Embree tracer must do for a semi-transparent surface (the furball's strands):
// multiply the ray's transmittance by (1 - opacity) and keep tracing until it is nearly
// zero. Without it the bare loop would stop at the first strand and answer a different,
// cheaper question than the reference's.
struct BareTransmittanceContext {
  RTCIntersectContext base;
  float* transmittance;  // indexed by RTCRay::id
};
struct BareOpacity {
  float opacity;
  const float* triangle_opacity;
};
void bare_transparency_filter(const RTCFilterFunctionNArguments* args) {
  auto* ctx = reinterpret_cast<BareTransmittanceContext*>(args->context);
  const auto* o = static_cast<const BareOpacity*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    float& t = ctx->transmittance[RTCRayN_id(args->ray, args->N, i)];
    t *= 1.0f - o->opacity * (o->triangle_opacity ? o->triangle_opacity[prim] : 1.0f);
    if (t > 1e-4f) args->valid[i] = 0;
  }
}

// The same rays through Embree directly: rtcOccluded1M on 256-ray streams, one thread per
// TBB task exactly like the reference, but nothing else (a transmittance filter only on
// semi-transparent objects, as above).
void BM_BareEmbree(benchmark::State& state, const std::string& name) {
  Fixture& f = fixture(name);
  RTCDevice device = rtcNewDevice(nullptr);
  RTCScene scene = rtcNewScene(device);
  std::vector<BareOpacity> opacity;
  opacity.reserve(f.scene.objects.size());
  for (const SceneObject& o : f.scene.objects) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          12, o.mesh.positions.size()));
    std::memcpy(v, o.mesh.positions.data(), 12 * o.mesh.positions.size());
    auto* idx = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12,
                                                               o.mesh.triangle_count()));
    std::memcpy(idx, o.mesh.indices.data(), 4 * o.mesh.indices.size());
    if (o.material.opacity < 1.0f || !o.mesh.triangle_opacity.empty()) {
      opacity.push_back({o.material.opacity,
                         o.mesh.triangle_opacity.empty() ? nullptr : o.mesh.triangle_opacity.data()});
      rtcSetGeometryUserData(g, &opacity.back());
      rtcSetGeometryOccludedFilterFunction(g, bare_transparency_filter);
    }
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
  }
  rtcCommitScene(scene);
  uint64_t rays = 0;
  for (auto _ : state) {
    std::atomic<uint64_t> blocked{0};
    parallel_for((f.rays.size() + 255) / 256, 1, [&](size_t b, size_t e) {
      RTCRay buf[256];
      float transmittance[256];
      for (size_t chunk = b; chunk < e; ++chunk) {
        size_t begin = chunk * 256, n = std::min<size_t>(256, f.rays.size() - begin);
        for (size_t i = 0; i < n; ++i) {
          const ShadowRay& s = f.rays[begin + i];
          RTCRay& r = buf[i];
          r.org_x = s.org.x; r.org_y = s.org.y; r.org_z = s.org.z;
          r.dir_x = s.dir.x; r.dir_y = s.dir.y; r.dir_z = s.dir.z;
          r.tnear = s.tnear; r.tfar = s.tfar; r.mask = ~0u; r.flags = 0; r.time = 0; r.id = i;
          transmittance[i] = 1.0f;
        }
        BareTransmittanceContext ctx;
        rtcInitIntersectContext(&ctx.base);
        ctx.transmittance = transmittance;
        rtcOccluded1M(scene, &ctx.base, buf, static_cast<unsigned>(n), sizeof(RTCRay));
        uint64_t local = 0;
        for (size_t i = 0; i < n; ++i) local += buf[i].tfar < 0;
        blocked += local;
      }
    });
    benchmark::DoNotOptimize(blocked.load());
    rays += f.rays.size();
  }
  state.counters["rays_per_s"] = benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsRate);
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);
}

void register_all() {
  for (const char* name : {"bunny", "plant", "furball"}) {
    benchmark::RegisterBenchmark((std::string("reference/") + name).c_str(), BM_ReferenceMethod, std::string(name))
        ->Unit(benchmark::kMillisecond)->UseRealTime();
    benchmark::RegisterBenchmark((std::string("bare_embree/") + name).c_str(), BM_BareEmbree, std::string(name))
        ->Unit(benchmark::kMillisecond)->UseRealTime();
  }
}

}  // namespace
}  // namespace penumbra

int main(int argc, char** argv) { return penumbra::bench::run_benchmarks(argc, argv, penumbra::register_all); }
