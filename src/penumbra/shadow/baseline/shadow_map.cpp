// Method `shadow-map`: the classic hard shadow map (Williams 1978) from the light's centre,
// with constant and slope-scaled depth bias (or the receiver's plane), and percentage-closer
// filtering (Reeves et al. 1987) over a (2 pcf + 1)^2 box of texels, bilinear by default (the
// 2 x 2 texels around the receiver at pcf = 0). The point-light shadow the `hard` method
// ray-traces, computed from one depth image; docs/methods/shadow-map.md.
#include <algorithm>
#include <atomic>

#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/shadow/partitions/light_partitions.h"
#include "penumbra/shadow/shadow_map_common.h"
#include "penumbra/shadow/shadow_method.h"

namespace penumbra {
namespace {

using shadow_map::BiasParams;

class ShadowMapMethod final : public ShadowMethod {
 public:
  explicit ShadowMapMethod(const ParamSet& p)
      : view_(shadow_map::view_params(p)),
        pcf_(p.get_int("pcf")),
        bilinear_(p.get_bool("bilinear")),
        bias_(shadow_map::bias_params(p)) {}

  void prepare(const ShadowContext& ctx) override {
    stats_.prepare_count++;
    map_.prepare(*ctx.scene, *ctx.light, stats_);
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    if (!map_.update(light, vs, view_, stats_)) {
      std::fill(out.visibility.begin(), out.visibility.end(), 0.0f);
      return;
    }
    ScopedPhase phase(stats_, "lookup");
    const shadow_map::ShadowDepthMap& sm = map_.map();
    const DepthMap& map = sm.map();
    const shader::ShadowBias bias = bias_.shared();
    std::atomic<uint64_t> texels{0};
    parallel_for(vs.size(), 4096, [&](size_t begin, size_t end) {
      uint64_t local = 0;
      for (size_t k = begin; k < end; ++k) {
        const ViewSample& s = vs.samples[k];
        uint32_t read = 0;
        // shadow_map_shared.h: PCF over (2 pcf + 1)^2 texels, bilinear or not.
        out.visibility[k] = shader::shadow_map_visibility(map.z.data(), map.opacity.data(), sm.shared(), bias, pcf_,
                                                          bilinear_, light.center, light.frame.n, s.p, s.ng,
                                                          ctx.scene->objects[s.object].closed, read);
        local += read;
      }
      texels += local;
      if (ctx.progress) ctx.progress->add(end - begin);
    });
    stats_.texels_visited += texels.load();
  }

 private:
  shadow_map::ViewParams view_;
  int pcf_;
  bool bilinear_;
  BiasParams bias_;
  shadow_map::LightCentreMap map_;
};

std::vector<ParamSpec> params() {
  std::vector<ParamSpec> p = shadow_map::common_param_specs(2048);
  p.push_back({"pcf", ParamType::Int, 0,
               "percentage-closer filtering: radius in texels of the (2 pcf + 1)^2 box of texels averaged (0: the "
               "receiver's own texel, or with bilinear the 2 x 2 around it)",
               {}, 0, 64});
  p.push_back({"bilinear", ParamType::Bool, true,
               "weigh the PCF box's texels by where the receiver falls between texel centres (a depth-compare "
               "sampler's linear filtering: at pcf = 0 the 2 x 2 texels around it); false: whole texels (pcf = 0: "
               "the one texel it falls in, a binary hard shadow)"});
  for (ParamSpec& s : partitions::param_specs(8, partitions::kResolvingDensity)) p.push_back(std::move(s));
  return p;
}

// One light's instance: the light-centre map and what fitting and rendering it allocate
// (shadow_map::add_map_memory); the lookups allocate nothing.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  shadow_map::add_map_memory(tally, p.get_int("resolution"), q);
  partitions::add_memory(tally, p, q);
  return tally.estimate();
}

const MethodRegistration registration({
    "shadow-map",
    "hard shadows from one depth map at the light centre: receiver-plane or slope-scaled depth bias, bilinear PCF",
    params(),
    [](const ParamSet& p) {
      return partitions::wrap(std::make_unique<ShadowMapMethod>(p), p, p.get_int("resolution"));
    },
    /*samples_light=*/false,
    memory,
    // Not tile-exact: the depth map is fitted to the rendered view samples (light_view_from),
    // so a crop's map has other texels than the whole frame's and its lookups differ near
    // shadow edges.
    /*tile_exact=*/false,
    // A textured light counts as its mean colour: the light is its centre, size or outline.
    /*uniform_light=*/true,
});

}  // namespace
}  // namespace penumbra
