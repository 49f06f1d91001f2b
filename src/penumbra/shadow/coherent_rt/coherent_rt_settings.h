// What `coherent-rt` reads from its parameter table (coherent_rt.cpp's registration), on either
// device.
#pragma once

#include <algorithm>
#include <span>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/scene/light.h"
#include "penumbra/shadow/coherent_rt/depth_image_tracer.h"
#include "penumbra/shadow/coherent_rt/reference_images.h"
#include "penumbra/shadow/coherent_rt/soft_shad.h"
#include "penumbra/shadow/near_field_shared.h"
#include "penumbra/shadow/params.h"

namespace penumbra::coherent_rt {

struct CoherentRtSettings {
  bool geometry = false;  // tracer=geometry: rays through the real geometry, not the depth images
  std::string views = "corners";
  ReferenceImageOptions images;
  TraceOptions trace;
  SoftShadOptions sampling;
  int tile = 32;
  bool own_plane = true;
  float near_field = 32.0f;  // narrowest penumbra the images answer for, in their texels at the point (near_field_length)
  bool light_field = true;   // rays' parts near the light, where casters beyond the images' cap may lie, traced
};

// What crt_near_field_length reads: the scale, near_field texels of the largest texel among the
// reference views per unit of depth (their windows differ a little), their shared depth axis (the
// eyes lie in the light's plane, the views look along its normal) and the light's width
// (near_field_light_width). scale 0: no near field.
struct NearFieldFrame {
  float scale = 0.0f;
  float light_width = 0.0f;
  Vec3f eye{0.0f}, forward{0.0f};
};
inline NearFieldFrame near_field_frame(float near_field, const AreaLight& light, std::span<const LightView> views) {
  NearFieldFrame f;
  if (views.empty()) return f;
  for (const LightView& v : views) f.scale = std::max(f.scale, near_field * v.texel_world_size(1.0f));
  f.light_width = shader::near_field_light_width(light.area());
  f.eye = views[0].eye();
  f.forward = views[0].forward();
  return f;
}

inline CoherentRtSettings coherent_rt_settings(const ParamSet& p) {
  CoherentRtSettings s;
  s.geometry = p.get_string("tracer") == "geometry";
  s.views = p.get_string("views");
  s.images.resolution = p.get_int("resolution");
  s.images.gap_bias = p.get_float("gap_bias");
  s.images.shadow_bias = p.get_float("shadow_bias");
  s.images.open_shadow_bias = p.get_float("open_shadow_bias");
  s.images.slope_bias = p.get_float("slope_bias");
  s.trace.minmax_clipping = p.get_bool("minmax_clipping");
  s.trace.connectedness = p.get_bool("connectedness");
  s.trace.clear_miss = p.get_bool("clear_miss");
  s.trace.occlusion_intervals = p.get_bool("occlusion_intervals");
  s.trace.ranking = p.get_bool("ranking");
  s.trace.hidden_blocks = p.get_bool("hidden_blocks");
  s.sampling.coherence = p.get_bool("coherence");
  s.sampling.sub_grid = p.get_int("sub_grid");
  s.sampling.reset_distance = p.get_float("reset_distance");
  s.sampling.shortcut = p.get_bool("shortcut");
  s.tile = p.get_int("tile");
  s.own_plane = p.get_bool("own_plane");
  s.near_field = p.get_float("near_field");
  s.light_field = p.get_bool("light_field");
  if (s.tile & (s.tile - 1)) throw Error("coherent-rt: tile={} must be a power of two", s.tile);
  return s;
}

// For tests: the occlusion-span lists' first length in the GPU version's next instances (0: the
// default), to make them overflow and grow.
void set_first_gpu_span_capacity_for_testing(int spans);

}  // namespace penumbra::coherent_rt
