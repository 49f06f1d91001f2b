// Method `lam`: layered attenuation maps (agrawala2000 §4), the fast-preview half of the
// paper's lighting workflow. prepare() precomputes the LDI once per light (one depth map
// per light sample, warped into the light centre's view by eq. 3 and counted per layer);
// evaluate() is the display phase: one projection and 1 or 4 texel lookups per view sample,
// independent of the number of light samples. The LDI survives camera changes.
// docs/methods/lam.md maps the paper to this code.
#include <atomic>
#include <istream>
#include <ostream>
#include <vector>

#include "penumbra/core/binary_io.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"
#include "penumbra/raster/raster_triangle.h"
#include "penumbra/raster/rasterizer.h"
#include "penumbra/shadow/lam/attenuation_map.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {

// The triangles of closed meshes that face away from every point of the light can never be
// the nearest surface seen from a light sample (a ray from outside enters a closed solid
// through a face turned toward it), so the per-sample depth maps are the same without them:
// about half of a closed mesh's triangles are not rasterized 64-256 times. Orientation
// (outward or inward windings) comes from the mesh's signed volume.
std::vector<RasterTriangle> cull_hidden_back_faces(const Scene& scene, const AreaLight& light,
                                                   const std::vector<RasterTriangle>& tris) {
  const std::vector<float> orientation = lam::closed_mesh_orientations(scene);
  const std::vector<Vec3f> outline = light.outline(32);
  std::vector<RasterTriangle> out;
  out.reserve(tris.size());
  for (const RasterTriangle& t : tris) {
    float orient = t.object < orientation.size() ? orientation[t.object] : 0.0f;
    if (orient != 0) {
      Vec3f n = cross(t.p[1] - t.p[0], t.p[2] - t.p[0]) * orient;
      bool behind = true;
      for (Vec3f q : outline)
        if (dot(q - t.p[0], n) >= 0) {
          behind = false;
          break;
        }
      if (behind) continue;
    }
    out.push_back(t);
  }
  return out;
}

class LayeredAttenuationMaps final : public ShadowMethod {
 public:
  explicit LayeredAttenuationMaps(const ParamSet& p)
      : options_(lam::build_options(p)),
        filter_(lam::display_filter(p)),
        trace_unresolved_(p.get_string("unresolved") == "trace"),
        trace_spread_(static_cast<float>(p.get_float("trace_spread"))) {}

  void prepare(const ShadowContext& ctx) override {
    stats_.prepare_count++;
    ScopedPhase phase(stats_, "precompute");
    const int n = std::max(1, ctx.light_samples);
    Timer t_fit;
    const ShadowRegion region = fit_shadow_region(*ctx.scene, *ctx.light);
    const double fit_ms = t_fit.elapsed_ms();
    const LightSampleSet set = lam::light_sample_set(ctx);
    Timer t_gather;
    const RasterTriangles all = gather_raster_triangles(*ctx.scene);
    const std::vector<RasterTriangle> tris = cull_hidden_back_faces(*ctx.scene, *ctx.light, all.list);
    const double gather_ms = t_gather.elapsed_ms();
    lam::BuildStats bs;
    map_ = lam::build_attenuation_map(RasterTriangleView(tris, &all.textures), *ctx.light, region, set.base(),
                                      lam::options_for_scene(options_, *ctx.scene), &bs);
    bs.fit_ms = fit_ms;
    set_display(ctx, set);

    extra_ = lam::build_statistics(bs, map_, n, map_.memory_bytes());
    extra_.update({
        {"precompute_ms",
         {{"fit", bs.fit_ms},
          {"gather", gather_ms},
          {"raster", bs.raster_ms},
          {"warp", bs.warp_ms},
          {"insert", bs.insert_ms},
          {"finalize", bs.finalize_ms}}},
        {"triangles", {{"scene", all.size()}, {"rasterized", tris.size()}}},
    });
    peak_bytes_ = bs.peak_bytes;
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    {
      ScopedPhase phase(stats_, "display");
      std::atomic<uint64_t> texels{0};
      parallel_for(vs.size(), 4096, [&](size_t b, size_t e) {
        uint64_t local = 0;
        map_.visibility(std::span<const ViewSample>(vs.samples).subspan(b, e - b), out.visibility.subspan(b, e - b),
                        filter_, &local);
        texels += local;
        if (ctx.progress) ctx.progress->add(e - b);
      });
      stats_.texels_visited += texels.load();
    }
    traced_samples_ = 0;
    if (trace_unresolved_) trace_unresolved(ctx, vs, out);
    // Stats are per frame (the Renderer clears them), the LDI is not: report it every frame.
    stats_.memory_bytes = std::max<uint64_t>(peak_bytes_, map_.memory_bytes());
    const std::string suffix = ctx.light_index == 0 ? "" : "_light" + std::to_string(ctx.light_index);
    for (auto it = extra_.begin(); it != extra_.end(); ++it) stats_.extra[it.key() + suffix] = it.value();
    if (trace_unresolved_) stats_.extra["traced_samples" + suffix] = traced_samples_;
  }

  // The LDI depends on the geometry, the light, the parameters, the seed and the light
  // samples, never on the camera: a second run with the same lights loads it (--map-cache)
  // and starts at display cost (agrawala2000 §4: precompute once, display many times).
  bool stores_prepared() const override { return true; }
  void save_prepared(std::ostream& out) const override {
    map_.write(out);
    const std::string extra = extra_.dump();
    binary::write_array(out, std::vector<char>(extra.begin(), extra.end()));
    binary::write<uint64_t>(out, peak_bytes_);
  }
  bool load_prepared(std::istream& in, const ShadowContext& ctx) override {
    lam::AttenuationMap map;
    std::vector<char> extra;
    uint64_t peak = 0;
    if (!map.read(in) || !binary::read_array(in, extra, uint64_t{1} << 30) || !binary::read(in, peak)) return false;
    nlohmann::json extra_json = nlohmann::json::parse(extra.begin(), extra.end(), nullptr, /*allow_exceptions=*/false);
    if (!extra_json.is_object()) return false;
    map_ = std::move(map);
    extra_ = std::move(extra_json);
    peak_bytes_ = peak;
    set_display(ctx, lam::light_sample_set(ctx));
    return true;
  }

  const lam::AttenuationMap& map() const { return map_; }

 private:
  // The display's options on a built or loaded map, and the light points of its samples.
  void set_display(const ShadowContext& ctx, const LightSampleSet& set) {
    map_.set_unresolved(trace_unresolved_, trace_spread_);
    light_points_ = lam::light_points(*ctx.light, set);
  }

  // The view samples the LDI does not resolve (the display returned kLamUnresolved: one of p's
  // texels does not hold p's surface, which the paper reads as umbra or lit, or their attenuations
  // differ by more than trace_spread, a shadow finer than the texels) take their V from the LDI's
  // own N light samples, traced: the fraction of the points q_i = sample_area(u_i) that p sees, a
  // light point behind a closed surface's own plane counting as blocked (its ray would enter the
  // solid). The same samples as the LDI, so a traced point keeps its neighbours' banding; the rays
  // are the exact answer the LDI approximates (docs/methods/lam.md "Points the LDI does not
  // resolve").
  void trace_unresolved(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) {
    ScopedPhase phase(stats_, "trace");
    std::vector<uint32_t> todo;
    for (size_t k = 0; k < vs.size(); ++k)
      if (out.visibility[k] < 0.0f) todo.push_back(static_cast<uint32_t>(k));
    if (!ctx.tracer) {  // no scene to trace (a bare context): the paper's umbra
      for (uint32_t k : todo) out.visibility[k] = 0.0f;
      traced_samples_ = todo.size();
      return;
    }
    std::atomic<uint64_t> rays{0};
    const int n = static_cast<int>(light_points_.size());
    parallel_for(todo.size(), 64, [&](size_t b, size_t e) {
      std::vector<float> x(n), y(n), z(n), t(n);
      uint64_t local = 0;
      for (size_t j = b; j < e; ++j) {
        const ViewSample& s = vs.samples[todo[j]];
        const bool closed = ctx.scene->objects[s.object].closed;
        int m = 0;
        for (const Vec3f& q : light_points_) {
          const Vec3f d = q - s.p;
          if (closed && dot(d, s.ng) <= 0.0f) continue;  // behind the solid's own plane: blocked
          x[m] = d.x;
          y[m] = d.y;
          z[m] = d.z;
          ++m;
        }
        float lit = 0.0f;
        if (m > 0) {
          ctx.tracer->transmittance_fan(s.p, s.ng, x.data(), y.data(), z.data(), m, t.data());
          for (int i = 0; i < m; ++i) lit += t[i];
        }
        out.visibility[todo[j]] = n > 0 ? lit / static_cast<float>(n) : 0.0f;
        local += static_cast<uint64_t>(m);
      }
      rays += local;
    });
    stats_.rays_traced += rays.load();
    traced_samples_ = todo.size();
  }

  lam::BuildOptions options_;
  lam::Filter filter_ = lam::Filter::Bilinear;
  bool trace_unresolved_ = true;
  float trace_spread_ = 0.005f;
  lam::AttenuationMap map_;
  std::vector<Vec3f> light_points_;  // sample_area of the LDI's light samples
  size_t traced_samples_ = 0;
  nlohmann::json extra_ = nlohmann::json::object();
  size_t peak_bytes_ = 0;
};

// One light's instance: the LDI and what building it holds (lam::build_bytes), the
// scene's triangles twice (gathered, and those left after culling hidden back faces) and the
// rasterizer's scratch for the sample views. The display allocates nothing; the light
// samples' own arrays (a few dozen bytes each, at most 65535) are left out.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  const int r = p.get_int("resolution");
  tally.add(lam::build_bytes(r, p.get_int("max_layers")), "resolution");
  const int side = lam::sample_view_side_bound(r);
  // The traced points' fans: the light points once, 4 floats a sample per worker (two).
  tally.add(static_cast<uint64_t>(std::max(1, q.light_samples)) * (sizeof(Vec3f) + 8 * sizeof(float)),
            kLightSamplesSetting);
  tally.add(2 * raster_triangles_bytes(q.triangles) + Rasterizer::scratch_bytes(q.triangles, side, side),
            kTrianglesSetting);
  return tally.estimate();
}

const MethodRegistration registration({
    "lam",
    "layered attenuation maps (agrawala2000 §4): an LDI at the light centre, precomputed once per light from "
    "--spp light-sample depth maps; fast display",
    {
        {"resolution", ParamType::Int, 512,
         "LDI texels along the longer side of the light-centre view (square texels; the view is fitted to the "
         "region where shadows can fall)",
         {}, 4, 8192},
        {"epsilon", ParamType::Float, 0.005,
         "depth tolerance, relative to the light-view linear depth: depths within epsilon * z are one surface "
         "(insertion and display); with local_planes, for closed objects' surfaces. A view narrower than 90 degrees "
         "(a light far from the scene) scales it (and open_epsilon) by its width over 2",
         {}, 0, 1},
        {"open_epsilon", ParamType::Float, 0.002,
         "with local_planes, the depth tolerance for open surfaces (leaves, cards, planes: objects that are not "
         "closed): flat per triangle, their depths are carried exactly along their planes, and a smaller tolerance "
         "keeps the leaves of a crown apart",
         {}, 0, 1},
        {"filter", ParamType::String, "bilinear",
         "display lookup: 'nearest' texel or 'bilinear' over the 4 neighbouring texels", {"nearest", "bilinear"}},
        {"local_planes", ParamType::Bool, true,
         "use each surface's local plane (penumbra's addition): compare depths at LDI texel centres, carried "
         "there along the plane, and on closed meshes hide the light behind a point's own tangent plane; "
         "false: the paper's plain rule |z - z_layer| <= epsilon z", {}},
        {"weighted_splats", ParamType::Bool, true,
         "with local_planes, a splat of an open surface adds its share of the texel (bilinear weight x the "
         "texels its pixel covers) instead of counting the texel once per light sample (penumbra's addition: "
         "gaps in a canopy are not counted several times over); false: the paper's count", {}},
        {"unresolved", ParamType::String, "trace",
         "the view samples the LDI does not resolve (a texel around them does not hold their surface, or their "
         "texels' attenuations differ by more than trace_spread): 'trace' the LDI's light samples from them "
         "(penumbra's addition: exact there) or 'umbra' (the paper's display: umbra where a layer lies in front, "
         "lit where none does)",
         {"trace", "umbra"}},
        {"trace_spread", ParamType::Float, 0.005,
         "with unresolved=trace, a point whose 4 texels' attenuations differ by more than this is traced too (a "
         "shadow finer than the LDI's texels); 1: only the points whose texels do not hold their surface",
         {}, 0, 1},
        {"max_layers", ParamType::Int, 32, "most layers one LDI texel holds while building (more are dropped)", {},
         1, 255},
    },
    [](const ParamSet& p) { return std::make_unique<LayeredAttenuationMaps>(p); },
    /*samples_light=*/true,
    memory,
});

}  // namespace
}  // namespace penumbra
