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
#include "penumbra/shadow/shadow_map_common.h"
#include "penumbra/shadow/shadow_method.h"

namespace penumbra {
namespace {

using shadow_map::BiasParams;
using shadow_map::in_front_of_light;
using shadow_map::kernel_offset;
using shadow_map::Receiver;

// Cranley-Patterson rotation: a toroidal shift keeps the stratification.
Vec2f rotate(Vec2f u, Vec2f shift) {
  u = u + shift;
  if (u.x >= 1.0f) u.x -= 1.0f;
  if (u.y >= 1.0f) u.y -= 1.0f;
  return u;
}

class Pcss final : public ShadowMethod {
 public:
  explicit Pcss(const ParamSet& p)
      : view_(shadow_map::view_params(p)),
        blocker_samples_(p.get_int("blocker_samples")),
        pcf_samples_(p.get_int("pcf_samples")),
        xie_(p.get_string("variant") == "xie2007"),
        jitter_(p.get_bool("jitter")),
        bias_(shadow_map::bias_params(p)) {}

  void prepare(const ShadowContext& ctx) override {
    stats_.prepare_count++;
    map_.prepare(*ctx.scene, stats_);
  }

  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override {
    const AreaLight& light = *ctx.light;
    if (!map_.update(light, vs, view_, stats_)) {
      std::fill(out.visibility.begin(), out.visibility.end(), 0.0f);
      return;
    }
    ScopedPhase phase(stats_, "filter");
    const shadow_map::ShadowDepthMap& sm = map_.map();
    const float focal = focal_texels(sm.view());
    const float z_min = sm.z_min();
    const uint64_t key = hash_combine(hash_combine(ctx.seed, 0x50435353u /* "PCSS" */ + ctx.light_index), ctx.frame);
    // Stratified kernels on the light's parameter square, shifted per pixel
    // (Cranley-Patterson) unless jitter=false.
    const std::vector<Vec2f> blocker_base = LightSampleSet(blocker_samples_, key, false).base();
    const std::vector<Vec2f> pcf_base = LightSampleSet(pcf_samples_, hash_combine(key, 1), false).base();
    std::atomic<uint64_t> texels{0}, no_blocker{0};
    parallel_for(vs.size(), 1024, [&](size_t begin, size_t end) {
      uint64_t local = 0, unblocked = 0;
      for (size_t k = begin; k < end; ++k) {
        const ViewSample& s = vs.samples[k];
        if (!in_front_of_light(light, s.p)) {
          out.visibility[k] = 0.0f;
          continue;
        }
        Receiver rc = sm.receiver(s.p, s.ng, bias_);
        if (xie_) {
          const bool closed = ctx.scene->objects[s.object].closed;
          out.visibility[k] = rc.faces || !closed ? xie2007(sm, rc, pcf_base, jitter_ ? Rng(key, 0x5050u, s.pixel).next_2d() : Vec2f(0, 0),
                                                 focal, light.extent_radius(), z_min, &local)
                                       : 0.0f;
          continue;
        }
        // On a closed object, light points behind p's own surface are blocked by it.
        const bool closed = ctx.scene->objects[s.object].closed;
        // 1. Blocker search over the light's shape projected onto z_min.
        const float search = rc.z > z_min ? 1.0f / z_min - 1.0f / rc.z : 0.0f;
        double sum = 0;
        int count = 0;
        const Vec2f shift = jitter_ ? Rng(key, 0x5050u, s.pixel).next_2d() : Vec2f(0, 0);
        for (int i = 0; i < blocker_samples_; ++i) {
          Vec3f q = light.sample_area(rotate(blocker_base[i], shift));
          if (closed && dot(s.ng, q - s.p) <= 0) continue;
          Vec2f t = rc.texel + kernel_offset(sm.view(), focal, q) * search;
          int x = static_cast<int>(std::floor(t.x)), y = static_cast<int>(std::floor(t.y));
          ++local;
          if (x < 0 || y < 0 || x >= sm.map().width || y >= sm.map().height) continue;
          float z = sm.map().z[sm.map().index(x, y)];
          if (z < sm.reference_depth(rc, x, y, bias_)) {
            sum += z;
            ++count;
          }
        }
        // 2. Penumbra estimate: the light's shape scaled by (1/d_b - 1/z_p).
        const float scale = count > 0 ? std::max(0.0f, 1.0f / static_cast<float>(sum / count) - 1.0f / rc.z) : 0.0f;
        unblocked += count == 0;
        // 3. PCF over that kernel (with no blocker, only p's own horizon darkens it).
        float v = 0;
        for (int i = 0; i < pcf_samples_; ++i) {
          Vec3f q = light.sample_area(rotate(pcf_base[i], shift));
          if (closed && dot(s.ng, q - s.p) <= 0) continue;
          if (count == 0) {
            v += 1.0f;
            continue;
          }
          v += sm.transmit_at(rc, rc.texel + kernel_offset(sm.view(), focal, q) * scale, bias_);
          ++local;
        }
        out.visibility[k] = v / static_cast<float>(pcf_samples_);
      }
      texels += local;
      no_blocker += unblocked;
      if (ctx.progress) ctx.progress->add(end - begin);
    });
    stats_.texels_visited += texels.load();
    stats_.extra["z_min"] = z_min;
    if (!xie_) stats_.extra["samples_without_blockers"] = no_blocker.load();
  }

 private:
  // xie2007 §3: stochastic samples in a disk of radius filter_size (eq. 1) around p's
  // texel; the fraction of blockers.
  float xie2007(const shadow_map::ShadowDepthMap& sm, const Receiver& rc, const std::vector<Vec2f>& base, Vec2f shift,
                float focal, float light_radius, float z_min, uint64_t* texels) const {
    const float radius = shadow_map::xie2007_filter_size(focal, light_radius, z_min, rc.z);
    float v = 0;
    for (int i = 0; i < pcf_samples_; ++i) {
      Vec2f d = square_to_disk_concentric(rotate(base[i], shift));
      v += sm.transmit_at(rc, rc.texel + d * radius, bias_);
    }
    *texels += pcf_samples_;
    return v / static_cast<float>(pcf_samples_);
  }

  shadow_map::ViewParams view_;
  int blocker_samples_;
  int pcf_samples_;
  bool xie_;
  bool jitter_;
  BiasParams bias_;
  shadow_map::LightCentreMap map_;
};

std::vector<ParamSpec> params() {
  std::vector<ParamSpec> p = shadow_map::common_param_specs(1024, /*receiver_plane_default=*/true);
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
  return p;
}

// One light's instance: the light-centre map and what fitting and rendering it allocate
// (shadow_map::add_map_memory), and the two kernels' stratified points.
MemoryEstimate memory(const ParamSet& p, const MemoryQuery& q) {
  MemoryTally tally;
  shadow_map::add_map_memory(tally, p.get_int("resolution"), q);
  tally.add(static_cast<uint64_t>(p.get_int("blocker_samples") + p.get_int("pcf_samples")) * sizeof(Vec2f),
            "pcf_samples");
  return tally.estimate();
}

const MethodRegistration registration({
    "pcss",
    "percentage-closer soft shadows from one depth map (Fernando 2005), or xie2007 §3's PCF based soft shadows",
    params(),
    [](const ParamSet& p) { return std::make_unique<Pcss>(p); },
    /*samples_light=*/false,
    memory,
    // Not tile-exact: the depth map is fitted to the rendered view samples (light_view_from),
    // so a crop's blocker search and filter read other texels than the whole frame's.
    /*tile_exact=*/false,
});

}  // namespace
}  // namespace penumbra
