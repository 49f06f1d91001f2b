// Methods `mlsm` and `mtsm`: soft shadows by ray tracing multilayer (transparent) shadow
// maps (xie2007). One map from the light's centre, pushed back by eq. 4 (§6.2), holds either
// the k nearest surfaces per texel (MLSM, §4.2) or every surface compressed deep-shadow style
// into (z_i, v_i, count_i) layers (MTSM, §5.1); N stochastic light samples per view sample
// are traced through it, hierarchically over its min/max quadtree (§4.3, §5.2). V is the
// area-weighted mean transmittance, with the same light sampling as `reference`.
// docs/methods/multilayer.md maps the paper to this code.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"
#include "penumbra/core/timer.h"
#include "penumbra/raster/caster_culling.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/shadow/multilayer/multilayer_map.h"
#include "penumbra/shadow/multilayer/multilayer_trace.h"
#include "penumbra/shadow/multilayer/multilayer_view_shared.h"
#include "penumbra/shadow/partitions/light_partitions.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {

using multilayer::OpaqueLayerMap;
using multilayer::TransparentMap;

enum class Kind { Opaque, Transparent };

class MultilayerMethod final : public ShadowMethod {
 public:
  MultilayerMethod(const ParamSet& p, Kind kind) : kind_(kind) {
    const multilayer::MultilayerSettings s = multilayer::multilayer_settings(p, kind == Kind::Transparent);
    options_ = s.view;
    fit_shadowable_ = s.fit_shadowable;
    z_thresh_ = s.z_thresh;
    z_thresh_texels_ = s.z_thresh_texels;
    trace_.self_bias = s.self_bias;
    trace_.open_self_bias = s.open_self_bias;
    layers_ = s.layers;
    compression_ = s.compression;
    trace_.stop_below = s.stop_below;
    trace_.near_field = s.near_field;
    trace_unresolved_ = s.trace_unresolved;
  }

  void prepare(const ShadowContext& ctx) override {
    stats_.prepare_count++;
    ScopedPhase phase(stats_, "gather");
    triangles_ = gather_raster_triangles(*ctx.scene);
    culling_.build(triangles_);
    scene_bounds_ = ctx.scene->bounds();
    built_ = false;
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    std::fill(out.visibility.begin(), out.visibility.end(), 0.0f);
    std::vector<Vec3f> receivers;
    receivers.reserve(vs.size());
    for (const ViewSample& s : vs.samples)
      if (shader::ml_is_receiver(light.center, light.frame.n, s.p)) receivers.push_back(s.p);
    if (receivers.empty()) return;
    build(*ctx.scene, light, receivers);
    multilayer::TraceSetup setup = multilayer::make_trace_setup(
        view_.view, kind_ == Kind::Opaque ? opaque_.z_min : transparent_.z_min, resolved_trace_);
    setup.segments_held_beyond = view_.segments_held_beyond;

    ScopedPhase phase(stats_, "trace");
    const int n = std::max(1, ctx.light_samples);
    const shader::MlTraceSetup near_shared =
        multilayer::shared_trace_setup(setup, kind_ == Kind::Opaque ? opaque_.z_min : transparent_.z_min);
    const StratifiedGrid grid(n);
    const Scene& scene = *ctx.scene;
    multilayer::TraceCounters total;
    std::mutex total_mutex;
    parallel_for(vs.size(), 16, [&](size_t begin, size_t end) {
      multilayer::TraceCounters local;
      // The point's light samples warped together (the SIMD kernels of scene/light_batch.h,
      // as `reference` draws them).
      const size_t padded = LightSampleBatch::padded(n);
      std::vector<float> ux(padded, 0.0f), uy(padded, 0.0f);
      LightSampleBatch batch;
      batch.resize(n);
      std::vector<Vec3f> q(n);
      std::vector<float> transmit(n);
      NearFields near(n);
      for (size_t k = begin; k < end; ++k) {
        const ViewSample& s = vs.samples[k];
        // Keyed by (seed, light, camera ray, frame): independent of thread count. The same
        // stream as `reference` (reference.cpp): at equal seed both draw the same light
        // samples, so their difference is the map's error, not noise.
        Rng rng(ctx.seed, 0x52454600u + ctx.light_index, sample_key(s), ctx.frame);
        const LightPointSampler sampler(light, s.p);
        if (!sampler.valid()) continue;  // p sees no part of the emitting side: V = 0
        const multilayer::RayReceiver r{s.p, s.ng, s.object < scene.objects.size() && scene.objects[s.object].closed};
        for (int i = 0; i < n; ++i) {
          const Vec2f u = grid.sample(i, rng.next_2d());
          ux[i] = u.x;
          uy[i] = u.y;
        }
        const int m = sampler.sample_batch(ux.data(), uy.data(), n, batch);
        for (int i = 0; i < m; ++i) q[i] = s.p + Vec3f(batch.x[i], batch.y[i], batch.z[i]);
        const std::span<const Vec3f> points(q.data(), static_cast<size_t>(m));
        // The point's rays walk the map together (they share its quadtree down to s.p).
        if (kind_ == Kind::Opaque)
          multilayer::trace_opaque(setup, opaque_, r, points, transmit.data(), &local);
        else
          multilayer::trace_transparent(setup, transparent_, r, points, transmit.data(), &local);
        if (ctx.tracer && (near_shared.near_field > 0 || trace_unresolved_))
          trace_near_fields(ctx, near_shared, s, points, near, transmit, &local);
        // Without an Embree scene (a bare context) a ray the map cannot answer for is lit, as
        // the paper's k layers answer it.
        for (int i = 0; i < m; ++i)
          if (transmit[i] == shader::kMlUnresolved) transmit[i] = 1.0f;
        double v = 0, wsum = 0;
        for (int i = 0; i < m; ++i) {
          v += transmit[i] * batch.area_weight[i];
          wsum += batch.area_weight[i];
        }
        out.visibility[k] = wsum > 0 ? static_cast<float>(v / wsum) : 0.0f;
      }
      {
        std::lock_guard<std::mutex> lock(total_mutex);
        total.add(local);
      }
      if (ctx.progress) ctx.progress->add(end - begin);
    });
    stats_.rays_traced += total.rays;
    stats_.texels_visited += total.texels;
    stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, memory_bytes());
    const std::string suffix = ctx.light_index == 0 ? "" : "_light" + std::to_string(ctx.light_index);
    // The frame's traces so far: the light-space partitions (partitions::wrap) evaluate one map
    // after another within a frame; the renderer resets the statistics between frames.
    if (!stats_.extra.contains("trace" + suffix)) frame_trace_ = {};
    frame_trace_.add(total);
    const multilayer::TraceCounters& t = frame_trace_;
    const double rays = t.rays ? static_cast<double>(t.rays) : 1.0;
    nlohmann::json e = build_extra_;
    e["trace"] = {{"rays", t.rays},
                  {"nodes_per_ray", t.nodes / rays},
                  {"texels_per_ray", t.texels / rays},
                  {"layers_tested_per_ray", t.layers_tested / rays},
                  {"layer_hits", t.layer_hits},
                  {"unresolved_rays", t.unresolved}};
    for (auto it = e.begin(); it != e.end(); ++it) stats_.extra[it.key() + suffix] = it.value();
  }

  const multilayer::CentreView& view() const { return view_; }

 private:
  // One point's near fields (ml_near_fraction): the first part of each of its rays, traced through
  // the scene (Embree's fan from the point), its transmittance times the map's answer for the rest
  // (mtsm), or blocking outright where anything is hit (mlsm: every caster opaque). A ray the map
  // could not answer for (kMlUnresolved: behind a full texel's k layers) is traced whole.
  struct NearFields {
    explicit NearFields(int n) : x(n), y(n), z(n), t(n), index(n) {}
    std::vector<float> x, y, z, t;
    std::vector<int> index;  // the ray of each near field
  };
  void trace_near_fields(const ShadowContext& ctx, const shader::MlTraceSetup& ss, const ViewSample& s,
                         std::span<const Vec3f> q, NearFields& near, std::vector<float>& transmit,
                         multilayer::TraceCounters* counters) const {
    const shader::RasterView& view = view_.view.shared();
    int m = 0;
    for (size_t i = 0; i < q.size(); ++i) {
      const bool unresolved = transmit[i] == shader::kMlUnresolved;
      if (!unresolved && transmit[i] <= 0.0f) continue;  // the map (or the receiver's own solid) already blocks it
      const float f = unresolved ? 1.0f : shader::ml_near_fraction(view, ss, s.p, q[i]);
      if (!(f > 0.0f)) continue;  // no near field: the map's answer stands
      if (unresolved) {
        transmit[i] = 1.0f;  // the whole ray is the trace's
        counters->unresolved++;
      }
      const Vec3f d = (q[i] - s.p) * f;
      near.x[m] = d.x;
      near.y[m] = d.y;
      near.z[m] = d.z;
      near.index[m++] = static_cast<int>(i);
    }
    if (m == 0) return;
    ctx.tracer->transmittance_fan(s.p, s.ng, near.x.data(), near.y.data(), near.z.data(), m, near.t.data());
    for (int j = 0; j < m; ++j) {
      float& t = transmit[near.index[j]];
      t = kind_ == Kind::Opaque ? (near.t[j] < 1.0f ? 0.0f : t) : t * near.t[j];
      if (kind_ == Kind::Transparent && t < resolved_trace_.stop_below) t = 0.0f;
    }
  }

  size_t memory_bytes() const {
    return kind_ == Kind::Opaque ? opaque_.memory_bytes() : transparent_.memory_bytes();
  }

  // Builds the map for these receivers (xie2007 §4.2 / §5.1), unless the one built last
  // already serves them (same light, same receiver bounds).
  void build(const Scene& scene, const AreaLight& light, const std::vector<Vec3f>& receivers) {
    Bounds3f rb;
    for (Vec3f p : receivers) rb.extend(p);
    if (built_ && rb.lo == receiver_bounds_.lo && rb.hi == receiver_bounds_.hi) return;
    ScopedPhase phase(stats_, "build");
    Timer t_view;
    const std::vector<Bounds3f> boxes = multilayer::caster_boxes(scene, light, receivers);
    const std::vector<Vec3f> fitted =
        fit_shadowable_ ? multilayer::shadowable_receivers(boxes, light, receivers) : receivers;
    view_ = multilayer::light_centre_view(light, fitted, scene_bounds_, options_,
                                          fit_shadowable_ ? std::span<const Bounds3f>(boxes) : std::span<const Bounds3f>());
    const double view_ms = t_view.elapsed_ms();
    Timer t_raster;
    float z_min;
    uint64_t culled = 0;
    const RasterTriangleView casters = culling_.visible(triangles_, view_.view, visible_, &culled);
    stats_.add_count("culled_triangles", culled);
    if (kind_ == Kind::Opaque) {
      multilayer::build_opaque_layer_map(rasterizer_, casters, view_.view, layers_, &opaque_, trace_unresolved_);
      z_min = opaque_.z_min;
    } else {
      multilayer::build_transparent_map(rasterizer_, casters, view_.view, compression_, &transparent_,
                                        trace_unresolved_);
      z_min = transparent_.z_min;
    }
    const double raster_ms = t_raster.elapsed_ms();
    // z_thresh in camera space (xie2007 §6.1); the automatic value is z_thresh_texels texel
    // widths at the geometric mean of the map's nearest depth and the farthest receiver.
    resolved_trace_ = multilayer::resolve_trace_params(trace_, view_.view, z_min, z_thresh_, z_thresh_texels_);
    resolved_trace_.light_width = shader::near_field_light_width(light.area());
    receiver_bounds_ = rb;
    built_ = true;

    // Statistics of the map: layers used per covered texel, memory.
    uint64_t covered = 0, layer_total = 0, max_layers = 0;
    const int w = view_.view.width(), h = view_.view.height();
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        uint64_t c = kind_ == Kind::Opaque ? opaque_.layers.count(x, y) : transparent_.layers.at(x, y).size();
        if (c) ++covered;
        layer_total += c;
        max_layers = std::max(max_layers, c);
      }
    build_extra_ = {
        {"map",
         {{"width", w},
          {"height", h},
          {"covered_texels", covered},
          {"layers", layer_total},
          {"layers_per_covered_texel", covered ? double(layer_total) / covered : 0.0},
          {"max_layers_in_a_texel", max_layers},
          {"bytes", memory_bytes()},
          {"push_back", view_.push_back},
          {"receivers", receivers.size()},
          {"receivers_fitted", fitted.size()},
          {"half_fov_degrees", view_.half_fov_deg},
          {"z_min", z_min},
          {"z_thresh", resolved_trace_.z_thresh}}},
        {"build_ms", {{"view", view_ms}, {"raster_and_layers", raster_ms}}},
    };
    if (kind_ == Kind::Transparent) build_extra_["map"]["fragments"] = transparent_.fragments;
  }

  Kind kind_;
  multilayer::ViewOptions options_;
  multilayer::CentreView view_;
  int layers_ = 5;
  multilayer::CompressionOptions compression_;
  float z_thresh_ = 0, z_thresh_texels_ = 1.0f;
  multilayer::TraceParams trace_, resolved_trace_;
  bool trace_unresolved_ = true;  // `unresolved`: the map's full texels marked, the rays behind them traced
  multilayer::TraceCounters frame_trace_;  // this frame's, over its partitions' evaluates
  RasterTriangles triangles_;
  CasterCulling culling_;  // the casters outside the fitted view are not rasterized
  std::vector<RasterTriangle> visible_;
  Bounds3f scene_bounds_, receiver_bounds_;
  bool built_ = false;
  bool fit_shadowable_ = true;
  Rasterizer rasterizer_;
  OpaqueLayerMap opaque_;
  TransparentMap transparent_;
  nlohmann::json build_extra_ = nlohmann::json::object();
};

std::vector<ParamSpec> common_specs() {
  return {
      {"resolution", ParamType::Int, 1024,
       "texels along the longer side of the light-centre map (square texels; fitted to the receivers and the light)",
       {}, 16, 16384},
      {"max_fov", ParamType::Float, 120.0, "largest field of view of the map, degrees", {}, 1, 179},
      {"push_back", ParamType::Bool, true,
       "push the light-centre eye back by d = light_radius / tan(fov/2) (xie2007 eq. 4) so casters outside the "
       "centre's frustum stay in the map",
       {}},
      {"fit_shadowable", ParamType::Bool, true,
       "fit the map to the receivers some caster can shadow (penumbra's addition; false: every receiver, so the "
       "ground's far parts stretch the view toward max_fov)",
       {}},
      {"z_thresh", ParamType::Float, 0.0,
       "depth threshold in light-view (camera) space, world units (xie2007 §6.1): a layer at z blocks a ray whose "
       "depth over the texel overlaps [z - z_thresh, z + z_thresh]; 0 = z_thresh_texels texel widths",
       {}, 0, 1e30},
      {"z_thresh_texels", ParamType::Float, 1.0,
       "the automatic z_thresh in texel widths, at the geometric mean of the map's nearest depth and its far plane",
       {}, 0, 1e6},
      {"self_bias", ParamType::Float, 0.25,
       "texel widths (at the receiver) around the receiver's own tangent plane where layer samples are ignored "
       "(its own surface is in the map); for receivers on closed objects",
       {}, 0, 1e6},
      {"open_self_bias", ParamType::Float, 0.1,
       "self_bias for receivers on open surfaces (leaves, cards, planes: objects that are not closed): flat per "
       "triangle, their own plane is exact, and a narrower band keeps the leaf just above in a canopy",
       {}, 0, 1e6},
      {"near_field", ParamType::Float, 32.0,
       "the map answers for occluders whose penumbra at the receiver is at least near_field texel widths wide; "
       "each shadow ray's part nearer its receiver than that is traced through the scene itself (penumbra's "
       "addition: there a ray meets surfaces the map holds only at texel centres and inside the own-surface "
       "band); 0: the paper's rays, the map alone",
       {}, 0, 1e6},
      {"unresolved", ParamType::String, "trace",
       "the rays that pass behind the last layer of a full texel, where the map dropped what lies behind (mlsm: k "
       "layers held; mtsm: its visibility at zero once more than `resets` allow) and that no layer blocks: "
       "'trace' them through the scene (penumbra's addition) or 'lit', the paper's answer",
       {"trace", "lit"}},
  };
}

std::vector<ParamSpec> mlsm_specs() {
  std::vector<ParamSpec> s = common_specs();
  for (ParamSpec& p : partitions::param_specs(8, partitions::kResolvingDensity)) s.push_back(std::move(p));
  s.push_back({"layers", ParamType::Int, 5, "k: nearest distinct surfaces kept per texel (xie2007 §4.2)", {}, 1, 255});
  return s;
}

std::vector<ParamSpec> mtsm_specs() {
  std::vector<ParamSpec> s = common_specs();
  for (ParamSpec& p : partitions::param_specs(8, partitions::kResolvingDensity)) s.push_back(std::move(p));
  s.push_back({"resets", ParamType::Int, 4,
               "times a texel's accumulated visibility may reach 0 and restart at 1 (xie2007 §5.1): layers behind an "
               "opaque run; on opaque scenes resets + 1 plays the role of mlsm's layers",
               {}, 0, 254});
  s.push_back({"error", ParamType::Float, 0.02,
               "deep-shadow compression tolerance: largest deviation of the compressed visibility from the "
               "original along the light-centre ray",
               {}, 0, 1});
  s.push_back({"stop_below", ParamType::Float, 1e-3,
               "a ray whose accumulated visibility falls below this is blocked and stops (xie2007 §5.2 threshold)",
               {}, 0, 1});
  return s;
}

// One light's instance (mlsm, mtsm): the map of a resolution^2 view (mlsm: `layers` layers
// per texel, every slot allocated; mtsm: resets + 1 compressed layers per texel, the most an
// opaque scene's texels hold, and its build's per-texel vectors) with its quadtree; the
// gathered triangles and the rasterizer's scratch; per view sample, the receivers, the
// fitted ones (grown by doubling) and which are kept, and the points the light-centre view
// is fitted to; per worker thread, one point's light samples and its rays' near fields.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q, Kind kind) {
  MemoryTally tally;
  const ViewSize v = fitted_view_bound(p.get_int("resolution"));
  tally.add(kind == Kind::Opaque ? OpaqueLayerMap::bytes(v.width, v.height, p.get_int("layers"))
                                 : TransparentMap::build_bytes(v.width, v.height, p.get_int("resets") + 1),
            "resolution");
  // The gathered triangles, the culled copy the view keeps (raster/caster_culling.h), the scratch.
  tally.add(2 * raster_triangles_bytes(q.triangles) + Rasterizer::scratch_bytes(q.triangles, v.width, v.height),
            kTrianglesSetting);
  const uint64_t outline = q.light ? q.light->outline(32).size() : 32;
  tally.add(q.view_samples * (3 * sizeof(Vec3f) + sizeof(uint8_t)) +
                multilayer::light_centre_view_bytes(q.view_samples, outline),
            kViewSamplesSetting);
  const int n = std::max(1, q.light_samples);
  const uint64_t per_thread = LightSampleBatch::bytes(n) + 2 * LightSampleBatch::padded(n) * sizeof(float) +
                              static_cast<uint64_t>(n) * (sizeof(Vec3f) + sizeof(float)) +
                              static_cast<uint64_t>(n) * (4 * sizeof(float) + sizeof(int));  // NearFields
  tally.add(static_cast<uint64_t>(q.threads) * per_thread, kLightSamplesSetting);
  partitions::add_memory(tally, p, q);
  return tally.estimate();
}

const MethodRegistration mlsm_registration({
    "mlsm",
    "ray tracing a k-layer shadow map from the (pushed-back) light centre (xie2007 §4): --spp stochastic rays per "
    "point through a min/max quadtree",
    mlsm_specs(),
    [](const ParamSet& p) {
      return partitions::wrap(std::make_unique<MultilayerMethod>(p, Kind::Opaque), p, p.get_int("resolution"),
                              multilayer::partition_guards(p));
    },
    /*samples_light=*/true,
    [](const ParamSet& p, const MemoryQuery& q) { return memory(p, q, Kind::Opaque); },
    // Not tile-exact: the layered map is fitted to the rendered view samples (build() ->
    // light_centre_view, its push-back from that fit too), so a crop's rays walk other texels.
    /*tile_exact=*/false,
});

const MethodRegistration mtsm_registration({
    "mtsm",
    "ray tracing a multilayer transparent shadow map (xie2007 §5): deep-shadow layers (z, v, count) per texel, "
    "visibility accumulated along --spp stochastic rays per point",
    mtsm_specs(),
    [](const ParamSet& p) {
      return partitions::wrap(std::make_unique<MultilayerMethod>(p, Kind::Transparent), p, p.get_int("resolution"),
                              multilayer::partition_guards(p));
    },
    /*samples_light=*/true,
    [](const ParamSet& p, const MemoryQuery& q) { return memory(p, q, Kind::Transparent); },
    // Not tile-exact: fitted to the rendered view samples, as mlsm.
    /*tile_exact=*/false,
});

}  // namespace
}  // namespace penumbra
