// Method `lam`: layered attenuation maps (agrawala2000 §4), the fast-preview half of the
// paper's lighting workflow. prepare() precomputes the LDI once per light (one depth map
// per light sample, warped into the light centre's view by eq. 3 and counted per layer);
// evaluate() is the display phase: one projection and 1 or 4 texel lookups per view sample,
// independent of the number of light samples. The LDI survives camera changes.
// docs/methods/lam.md maps the paper to this code.
#include <atomic>
#include <istream>
#include <ostream>

#include "penumbra/core/binary_io.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"
#include "penumbra/raster/raster_triangle.h"
#include "penumbra/raster/rasterizer.h"
#include "penumbra/shadow/lam/attenuation_map.h"
#include "penumbra/shadow/shadow_method.h"

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
      : options_(lam::build_options(p)), filter_(lam::display_filter(p)) {}

  void prepare(const ShadowContext& ctx) override {
    stats_.prepare_count++;
    ScopedPhase phase(stats_, "precompute");
    const int n = std::max(1, ctx.light_samples);
    Timer t_fit;
    const lam::ShadowRegion region = lam::fit_shadow_region(*ctx.scene, *ctx.light);
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
    // Stats are per frame (the Renderer clears them), the LDI is not: report it every frame.
    stats_.memory_bytes = std::max<uint64_t>(peak_bytes_, map_.memory_bytes());
    const std::string suffix = ctx.light_index == 0 ? "" : "_light" + std::to_string(ctx.light_index);
    for (auto it = extra_.begin(); it != extra_.end(); ++it) stats_.extra[it.key() + suffix] = it.value();
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
    return true;
  }

  const lam::AttenuationMap& map() const { return map_; }

 private:
  lam::BuildOptions options_;
  lam::Filter filter_ = lam::Filter::Bilinear;
  lam::AttenuationMap map_;
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
         "(insertion and display); with local_planes, for closed objects' surfaces",
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
        {"max_layers", ParamType::Int, 32, "most layers one LDI texel holds while building (more are dropped)", {},
         1, 255},
    },
    [](const ParamSet& p) { return std::make_unique<LayeredAttenuationMaps>(p); },
    /*samples_light=*/true,
    memory,
});

}  // namespace
}  // namespace penumbra
