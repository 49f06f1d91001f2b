// Method `multi-view-sm`: one depth map per light sample, averaged. N = --spp stratified
// points q_i on the light (one fixed LightSampleSet per frame, AreaLight::sample_area);
// from each, a depth map looking along the light's normal and fitted to the receivers; a
// view sample's V is the fraction of the maps in which it is lit (its transmittance
// through the nearest surface, with the biases of shadow_map_common.h; on closed objects,
// light points behind its own surface count as blocked). This is the brute-force image-based soft shadow that
// xie2007 §3 calls the first reference method ("around 1000 light samples") and that
// sintorn2008 compares against ("one shadow map per light sample").
//
// The near field (penumbra's addition, issue 34; shadow_map_shared.h sm_near_field_length): where
// an occluder's penumbra at p would be narrower than `near_field` texels of the maps, the maps'
// average cannot draw it (each answers a texel-sized hard shadow at the same texels), so that part
// of each shadow ray is traced through the scene (Embree) and the map answers for the rest, as
// hybrid ray-traced shadows do with a shadow map and rays near the receiver.
//
// Memory stays bounded by one map: render map i, test every view sample against it
// (parallel over view samples), accumulate, go on to map i + 1. One Rasterizer serves all
// maps. docs/methods/multi-view-sm.md.
#include <algorithm>
#include <atomic>
#include <vector>

#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/sampling.h"
#include "penumbra/shadow/baseline/multi_view_shared.h"
#include "penumbra/shadow/partitions/light_partitions.h"
#include "penumbra/shadow/shadow_map_common.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {

using shadow_map::BiasParams;
using shadow_map::in_front_of_light;

class MultiViewShadowMap final : public ShadowMethod {
 public:
  explicit MultiViewShadowMap(const ParamSet& p)
      : view_(shadow_map::view_params(p)), bias_(shadow_map::bias_params(p)), near_field_(p.get_float("near_field")) {}

  void prepare(const ShadowContext& ctx) override {
    ScopedPhase phase(stats_, "gather");
    stats_.prepare_count++;
    triangles_ = gather_raster_triangles(*ctx.scene);
    culling_.build(triangles_);
    scene_bounds_ = ctx.scene->bounds();
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    const size_t n = vs.size();
    std::fill(out.visibility.begin(), out.visibility.end(), 0.0f);
    culled_ = 0;
    const std::vector<Vec3f> receivers = shadow_map::receiver_points(vs, light);
    if (receivers.empty()) return;
    const int maps = std::max(1, ctx.light_samples);
    // The same light points for every view sample (agrawala2000 §3's fixed set): banding,
    // no noise. Keyed by (seed, light, frame) so progressive frames take new points.
    const LightSampleSet set(maps, hash_combine(hash_combine(ctx.seed, 0x4d5653u /* "MVS" */ + ctx.light_index), ctx.frame),
                             /*per_pixel=*/false);
    std::atomic<uint64_t> texels{0}, near_rays{0};
    // The near field needs the Embree scene (a bare context without one: the maps alone).
    const float near_field = ctx.tracer ? near_field_ : 0.0f;
    const float light_width = shader::near_field_light_width(light.area());
    for (int i = 0; i < maps; ++i) {
      const Vec3f q = light.sample_area(set.sample(i, 0));
      LightView view;
      {
        ScopedPhase phase(stats_, "fit");
        view = shadow_map::light_view_from(light, q, receivers, scene_bounds_, view_.resolution, view_.max_fov);
      }
      {
        ScopedPhase phase(stats_, "raster");
        uint64_t culled = 0;
        map_.render(rasterizer_, culling_.visible(triangles_, view, visible_, &culled), view);
        culled_ += culled;
      }
      ScopedPhase phase(stats_, "lookup");
      const shader::ShadowMapView& m = map_.shared();
      const DepthMap& planes = map_.map();
      parallel_for(n, 4096, [&](size_t begin, size_t end) {
        uint64_t local = 0;
        // The near fields of the view samples the map lets light through, traced as one stream.
        std::vector<ShadowRay> rays;
        std::vector<uint32_t> traced;
        std::vector<float> far, transmit;
        for (size_t k = begin; k < end; ++k) {
          const ViewSample& s = vs.samples[k];
          if (!in_front_of_light(light, s.p)) continue;
          ++local;
          const bool closed = ctx.scene->objects[s.object].closed;
          const float near = shader::mv_traced_length(m, s.p, near_field, light_width);
          const float t = shader::mv_far_lookup(planes.z.data(), planes.opacity.data(), m, s.p, s.ng, closed,
                                                bias_.shared(), near);
          if (t > 0.0f && near > 0.0f) {
            ShadowRay r = shadow_ray_to(s.p, s.ng, m.view.eye);
            r.tfar = std::min(r.tfar, near);
            rays.push_back(r);
            traced.push_back(static_cast<uint32_t>(k));
            far.push_back(t);
          } else {
            out.visibility[k] += t;
          }
        }
        if (!rays.empty()) {
          transmit.resize(rays.size());
          ctx.tracer->transmittance(rays, transmit);
          for (size_t j = 0; j < rays.size(); ++j) out.visibility[traced[j]] += far[j] * transmit[j];
          near_rays += rays.size();
        }
        texels += local;
      });
      if (ctx.progress) ctx.progress->add(n * (i + 1) / maps - n * i / maps);
    }
    const float inv = 1.0f / static_cast<float>(maps);
    for (float& v : out.visibility) v *= inv;
    stats_.texels_visited += texels.load();
    stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, map_.memory_bytes());
    stats_.extra["maps"] = maps;
    stats_.add_count("near_field_rays", near_rays.load());
    stats_.extra["culled_triangles"] = culled_;
    stats_.extra["map_width"] = map_.map().width;
    stats_.extra["map_height"] = map_.map().height;
  }

 private:
  shadow_map::ViewParams view_;
  BiasParams bias_;
  float near_field_;  // sm_near_field_length's texels (0: the maps alone)
  RasterTriangles triangles_;
  CasterCulling culling_;  // the casters outside a sample's fitted view are not rasterized
  std::vector<RasterTriangle> visible_;
  uint64_t culled_ = 0;
  Bounds3f scene_bounds_;
  Rasterizer rasterizer_;
  shadow_map::ShadowDepthMap map_;
};

std::vector<ParamSpec> params() {
  std::vector<ParamSpec> p = shadow_map::common_param_specs(512);
  p.push_back({"near_field", ParamType::Float, 32.0,
               "the maps answer for occluders whose penumbra at the point is at least near_field of their texels "
               "wide; each shadow ray's part nearer its point than that is traced through the scene itself "
               "(penumbra's addition, as hybrid ray-traced shadows: the maps' average draws a narrower penumbra as "
               "texel steps); 0: the maps alone",
               {}, 0, 1e6});
  // One map per light sample already: partitions multiply that, so they are asked for.
  for (ParamSpec& s : partitions::param_specs(/*default_partitions=*/1)) p.push_back(std::move(s));
  return p;
}

// One light's instance: one map at a time, whatever --spp (shadow_map::add_map_memory), and
// the light points of a frame.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  shadow_map::add_map_memory(tally, p.get_int("resolution"), q);
  tally.add(static_cast<uint64_t>(std::max(1, q.light_samples)) * sizeof(Vec2f), kLightSamplesSetting);
  partitions::add_memory(tally, p, q);
  return tally.estimate();
}

const MethodRegistration registration({
    "multi-view-sm",
    "one depth map per light sample (--spp stratified points on the light), averaged",
    params(),
    [](const ParamSet& p) {
      return partitions::wrap(std::make_unique<MultiViewShadowMap>(p), p, p.get_int("resolution"));
    },
    /*samples_light=*/true,
    memory,
    // Not tile-exact: each light point's depth map is fitted to the rendered view samples
    // (light_view_from), so a crop's maps have other texels than the whole frame's.
    /*tile_exact=*/false,
});

}  // namespace
}  // namespace penumbra
