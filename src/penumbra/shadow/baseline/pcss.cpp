// Method `pcss`: percentage-closer soft shadows (Fernando 2005) from one depth map at the
// light's centre, and the older "PCF based soft shadows" of xie2007 §3 as a variant.
// docs/methods/pcss.md.
//
// variant=fernando (default), per view sample p at linear depth z_p:
//  1. Blocker search: the region of the map where a blocker between p and the light can
//     appear is the light's shape projected through p onto the nearest depth of the map
//     (z_min): kernel_offset(q) * (1/z_min - 1/z_p) around p's texel for light points q.
//     `blocker_samples` stratified light points; a texel blocks when its depth is in front
//     of p (shadow_map_common.h). d_b = mean depth of the blockers found; none: lit.
//  2. Penumbra estimate: w = (z_p - d_b) * light_size / d_b (parallel planes: receiver,
//     blocker at d_b, light); as a filter it is the light's shape scaled by
//     (1/d_b - 1/z_p), i.e. Fernando's w * near / z_p in map units.
//  3. PCF: `pcf_samples` stratified light points q_i, each looked up at
//     texel(p) + kernel_offset(q_i) * (1/d_b - 1/z_p): the point where the segment from p
//     to q_i crosses the plane at d_b. V = mean transmittance (on closed objects, light
//     points behind p's own surface count as blocked). With one blocker plane this is exact; the artifacts come
//     from pretending every blocker lies at d_b.
// variant=xie2007 (§3, eq. 1): no blocker search; filter radius
//   filter_size = resolution * light_radius * (1/z_min - 1/p.z) texels (z_min: the map's
//   smallest depth, light_radius = AreaLight::extent_radius), `pcf_samples` stratified
//   points in that disk, V = 1 - fraction of blockers.
// Kernels are stratified on the light's (or the disk's) parameter square and rotated per
// pixel (Cranley-Patterson), so banding becomes noise, or fixed with jitter=false.
#include <algorithm>
#include <atomic>

#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/sampling.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/shadow/baseline/pcss_common.h"
#include "penumbra/shadow/partitions/light_partitions.h"
#include "penumbra/shadow/shadow_map_common.h"
#include "penumbra/shadow/shadow_method.h"

namespace penumbra {
namespace {

class Pcss final : public ShadowMethod {
 public:
  explicit Pcss(const ParamSet& p) : s_(p) {}

  void prepare(const ShadowContext& ctx) override {
    stats_.prepare_count++;
    map_.prepare(*ctx.scene, *ctx.light, stats_);
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    if (!map_.update(light, vs, s_.view, stats_)) {
      std::fill(out.visibility.begin(), out.visibility.end(), 0.0f);
      return;
    }
    ScopedPhase phase(stats_, "filter");
    const shadow_map::ShadowDepthMap& sm = map_.map();
    const DepthMap& map = sm.map();
    const shader::ShadowBias bias = s_.bias.shared();
    const uint64_t key = pcss::kernel_key(ctx);
    const pcss::Kernels kernels = pcss::kernels(s_, key);
    const shader::PcssLight pl = pcss::shared_light(light);
    const PiecewiseConstant2D* table = pcss::light_table(light);
    const float* marginal = table ? table->marginal_cdf().data() : nullptr;
    const float* conditional = table ? table->conditional_cdf().data() : nullptr;
    std::atomic<uint64_t> texels{0}, no_blocker{0};
    parallel_for(vs.size(), 1024, [&](size_t begin, size_t end) {
      uint64_t local = 0, unblocked = 0;
      for (size_t k = begin; k < end; ++k) {
        const ViewSample& s = vs.samples[k];
        const Vec2f shift = s_.jitter ? pcss::pixel_shift(key, s.pixel) : Vec2f(0, 0);
        uint32_t read = 0;
        bool none = false;
        // shadow_map_shared.h: blocker search, penumbra estimate, PCF (or xie2007's filter).
        out.visibility[k] = shader::pcss_visibility(
            map.z.data(), map.opacity.data(), sm.shared(), bias, pl, marginal, conditional,
            reinterpret_cast<const float*>(kernels.blocker.data()), s_.blocker_samples,
            reinterpret_cast<const float*>(kernels.pcf.data()), s_.pcf_samples, s_.xie2007 ? 1u : 0u, shift, s.p, s.ng,
            ctx.scene->objects[s.object].closed, read, none);
        local += read;
        unblocked += none;
      }
      texels += local;
      no_blocker += unblocked;
      if (ctx.progress) ctx.progress->add(end - begin);
    });
    stats_.texels_visited += texels.load();
    stats_.extra["z_min"] = sm.z_min();
    if (!s_.xie2007) stats_.add_count("samples_without_blockers", no_blocker.load());
  }

 private:
  pcss::Settings s_;
  shadow_map::LightCentreMap map_;
};

std::vector<ParamSpec> params() {
  std::vector<ParamSpec> p = shadow_map::common_param_specs(1024);
  p.push_back({"variant", ParamType::String, "fernando",
               "'fernando': blocker search, penumbra estimate, PCF (Fernando 2005); 'xie2007': the PCF based soft "
               "shadows of xie2007 §3, filter size from eq. 1 and the map's smallest depth",
               {"fernando", "xie2007"}});
  p.push_back({"blocker_samples", ParamType::Int, 32,
               "light points (stratified) whose projections are searched for blockers (fernando)", {}, 1, 4096});
  p.push_back({"pcf_samples", ParamType::Int, 64, "texels averaged by the filter (stratified over the light / disk)",
               {}, 1, 4096});
  p.push_back({"jitter", ParamType::Bool, true,
               "rotate the kernels per pixel (Cranley-Patterson): noise instead of banding; false: one fixed kernel",
               {}});
  for (ParamSpec& s : partitions::param_specs()) p.push_back(std::move(s));
  return p;
}

// One light's instance: the light-centre map and what fitting and rendering it allocate
// (shadow_map::add_map_memory), and the two kernels' stratified points.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  shadow_map::add_map_memory(tally, p.get_int("resolution"), q);
  tally.add(static_cast<uint64_t>(p.get_int("blocker_samples") + p.get_int("pcf_samples")) * sizeof(Vec2f),
            "pcf_samples");
  partitions::add_memory(tally, p, q);
  return tally.estimate();
}

const MethodRegistration registration({
    "pcss",
    "percentage-closer soft shadows from one depth map (Fernando 2005), or xie2007 §3's PCF based soft shadows",
    params(),
    [](const ParamSet& p) { return partitions::wrap(std::make_unique<Pcss>(p), p, p.get_int("resolution")); },
    /*samples_light=*/false,
    memory,
    // Not tile-exact: the depth map is fitted to the rendered view samples (light_view_from),
    // so a crop's blocker search and filter read other texels than the whole frame's.
    /*tile_exact=*/false,
});

}  // namespace
}  // namespace penumbra
