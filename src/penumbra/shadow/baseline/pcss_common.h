// What `pcss` is on both devices (pcss.cpp, pcss_gpu.cpp): its settings from the one parameter
// table, the key its kernels are drawn with, the kernels, and the light as the shared function
// (shadow_map_shared.h pcss_visibility) takes it. Same settings and same key: the CPU and the GPU
// draw the same stratified points and the same per-pixel shifts.
#pragma once

#include <vector>

#include "penumbra/core/rng.h"
#include "penumbra/core/sampling.h"
#include "penumbra/shadow/shadow_map_common.h"

namespace penumbra::pcss {

struct Settings {
  explicit Settings(const ParamSet& p)
      : view(shadow_map::view_params(p)),
        blocker_samples(p.get_int("blocker_samples")),
        pcf_samples(p.get_int("pcf_samples")),
        xie2007(p.get_string("variant") == "xie2007"),
        jitter(p.get_bool("jitter")),
        bias(shadow_map::bias_params(p)) {}
  shadow_map::ViewParams view;
  int blocker_samples;
  int pcf_samples;
  bool xie2007;  // variant=xie2007
  bool jitter;
  shadow_map::BiasParams bias;
};

// The kernels' key for one light and frame; a pixel's Cranley-Patterson shift is
// Rng(key, 0x5050, pixel).next_2d().
inline uint64_t kernel_key(const ShadowContext& ctx) {
  return hash_combine(hash_combine(ctx.seed, 0x50435353u /* "PCSS" */ + ctx.light_index), ctx.frame);
}
inline Vec2f pixel_shift(uint64_t key, uint32_t pixel) { return Rng(key, 0x5050u, pixel).next_2d(); }

// Stratified kernels on the light's (or the disk's) parameter square: the blocker search's and
// the filter's.
struct Kernels {
  std::vector<Vec2f> blocker, pcf;
};
inline Kernels kernels(const Settings& s, uint64_t key) {
  return {LightSampleSet(s.blocker_samples, key, false).base(), LightSampleSet(s.pcf_samples, hash_combine(key, 1), false).base()};
}

// The light as pcss_visibility takes it; its sampling table (a textured light's, which
// AreaLight::sample_area follows) or null.
inline const PiecewiseConstant2D* light_table(const AreaLight& light) {
  return light.textured() ? &light.texture->table(light.texture_channel) : nullptr;
}
inline shader::PcssLight shared_light(const AreaLight& light) {
  shader::PcssLight l{};
  l.geometry = light.geometry();
  if (const PiecewiseConstant2D* t = light_table(light)) {
    l.textured = 1;
    l.table_width = t->width();
    l.table_height = t->height();
  }
  l.extent_radius = light.extent_radius();
  return l;
}

}  // namespace penumbra::pcss
