#include "penumbra/shadow/filtered_moments/filtered_moments.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/shadow/filtered_moments/models.h"
#include "penumbra/shadow/light_horizon.h"
#include "penumbra/shadow/partitions/light_partitions.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra::filtered_moments {

// The view samples' rule of the light-space partitions (partition_receivers) by default: off. A
// filtered map's point is one map and its prefilter for a frame; where only the camera's samples
// are dense (a single object seen from near) more maps would each pay the prefilter.
constexpr double kFilteredReceivers = 0.0;

void FilteredMomentMap::build(const DepthMap& map, const MomentModel& model, Prefilter prefilter) {
  prefilter_ = prefilter;
  width_ = map.width;
  height_ = map.height;
  const int C = channels_ = model.channels();
  const shader::FmModel record = model.shared();
  float lo = kInfinity, hi = -kInfinity;
  for (float z : map.z)
    if (z < kInfinity) {
      lo = std::min(lo, z);
      hi = std::max(hi, z);
    }
  range_ = shader::fm_depth_range(lo, hi, kNear, kFar, kTinyRange);
  // Encode every texel (an empty one as depth 1), then prefilter.
  std::vector<float> texels(static_cast<size_t>(map.width) * map.height * C);
  parallel_for(map.z.size(), 4096, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) {
      const shader::FilteredChannels m = shader::fm_encode_texel(record, range_, map.z[i]);
      for (int c = 0; c < C; ++c) texels[i * C + c] = static_cast<float>(m.v[c]);
    }
  });
  float outside[4];
  model.encode(1.0, outside);
  outside_ = {};
  for (int c = 0; c < C; ++c) outside_.v[c] = outside[c];
  const ChannelImage image{map.width, map.height, C, texels};
  sat_ = SummedAreaTable();
  mip_ = MipChain();
  if (prefilter == Prefilter::Sat) sat_.build(image, std::span<const float>(outside, C));
  else mip_.build(image, std::span<const float>(outside, C));
}

uint64_t FilteredMomentMap::bytes(int width, int height, int channels, Prefilter prefilter) {
  const uint64_t encoded = static_cast<uint64_t>(width) * height * channels * sizeof(float);
  return encoded + (prefilter == Prefilter::Sat ? SummedAreaTable::bytes(width, height, channels)
                                                : MipChain::bytes(width, height, channels));
}

shader::FmMapRef FilteredMomentMap::ref() const {
  shader::FmMapRef r{};
  r.prefilter = prefilter_ == Prefilter::Sat ? shader::kFmPrefilterSat : shader::kFmPrefilterMip;
  r.width = width_;
  r.height = height_;
  r.sat = sat_.data();
  r.sat_layout = sat_.layout();
  r.outside = outside_;
  r.mip = mip_.texels();
  r.mip_view = mip_.view();
  r.range = range_;
  return r;
}

void FilteredMomentMap::mean(double x0, double y0, double x1, double y1, double* out) const {
  const shader::FilteredChannels m = shader::fm_mean(ref(), x0, y0, x1, y1);
  std::copy(m.v, m.v + channels_, out);
}

namespace {

// The light's rectangle's half extent along the axes `right` and `up`.
Vec2f half_extent(const AreaLight& light, Vec3f right, Vec3f up) {
  const Vec2f h = light_half_axes(light);
  const Vec3f s = light.frame.s, t = light.frame.t;
  return {std::abs(dot(s, right)) * h.x + std::abs(dot(t, right)) * h.y,
          std::abs(dot(s, up)) * h.x + std::abs(dot(t, up)) * h.y};
}

}  // namespace

Vec2f light_half_extent(const AreaLight& light, const LightView& view) {
  return half_extent(light, view.right(), view.up());
}

shader::FmShadeBlock shade_block(const CoreParams& params, const AreaLight& light, const shader::ShadowMapView& map) {
  shader::FmShadeBlock b{};
  b.map = map;
  b.light = horizon_light(light);
  // Texels per unit of (1/z_b - 1/z_p).
  b.half_extent = half_extent(light, map.view.right, map.view.up) * map.focal;
  b.min_half = 0.5 * params.min_filter;
  b.fixed_half = 0.5 * params.filter_size;
  b.bias = params.bias;
  b.blocker_search = params.blocker_search ? 1u : 0u;
  // A fraction this small is the receiver's own surface in the Chebyshev bound's tail.
  b.min_fraction = 1e-4;
  b.subdivide = static_cast<uint32_t>(params.subdivide);
  b.near_field = params.near_field;
  b.light_width = shader::near_field_light_width(light.area());
  return b;
}

std::vector<ParamSpec> core_param_specs(int default_resolution, Prefilter default_prefilter) {
  std::vector<ParamSpec> specs = {
      {"resolution", ParamType::Int, default_resolution,
       "texels along the longer side of the depth map (fitted to the receivers, as shadow-map's)", {}, 16, 8192},
      {"max_fov", ParamType::Float, 120.0,
       "largest field of view of the map, degrees: receivers beyond it are not covered and count as lit", {}, 1, 179},
      {"prefilter", ParamType::String, default_prefilter == Prefilter::Sat ? "sat" : "mipmap",
       "'sat': summed-area table in doubles (the exact box filter of any rectangle); 'mipmap': float mip chain, a "
       "grid of bilinear taps blended between two levels (no differences of large sums: for large EVSM exponents)",
       {"sat", "mipmap"}},
      {"blocker_search", ParamType::Bool, true,
       "PCSS-style contact hardening: filter width from the blockers' mean depth (estimated from the moments over "
       "the search region) and the light's size; false: a fixed filter of filter_size texels",
       {}},
      {"filter_size", ParamType::Float, 4.0, "filter side in texels when blocker_search=false", {}, 0, 4096},
      {"min_filter", ParamType::Float, 1.0, "smallest filter side in texels (the map's own resolution)", {}, 0, 4096},
      {"bias", ParamType::Float, 2e-3, "depth bias, world units of linear depth, subtracted from the receiver's depth; kept between 64 float epsilons of that depth and one texel (a scene in any unit)",
       {}, 0, 1e30},
      {"subdivide", ParamType::Int, 4,
       "most parts a side the blocker search and the filter are split into (one per two texels), each its own "
       "moment estimate against the receiver plane's depth at its centre (Yang et al. 2010's kernel subdivision: "
       "less light bleeding where a region holds blockers in front of the receiver and surfaces behind it); 1: "
       "one estimate over each region",
       {}, 1, 16},
      {"near_field", ParamType::Float, 2.0,
       "where an occluder's penumbra at the point would be narrower than near_field texels of the map, one ray "
       "toward the light's centre is traced over that part and V multiplied by its transmittance (penumbra's "
       "addition, as hybrid ray-traced shadows: there the filtered map bleeds light through a mix of depths and a "
       "penumbra that narrow is close to the hard shadow); 0: the map alone",
       {}, 0, 1e6},
  };
  // A filtered map samples its casters (four texels a caster triangle, as pcss's) and splits only
  // where they are dense: the view samples' rule is off by default (kFilteredReceivers).
  for (ParamSpec& s : partitions::param_specs(8, partitions::kSamplingDensity, kFilteredReceivers))
    specs.push_back(std::move(s));
  return specs;
}

CoreParams core_params(const ParamSet& p) {
  CoreParams c;
  c.view.resolution = p.get_int("resolution");
  c.view.max_fov = p.get_float("max_fov");
  c.prefilter = p.get_string("prefilter") == "mipmap" ? Prefilter::Mipmap : Prefilter::Sat;
  c.blocker_search = p.get_bool("blocker_search");
  c.filter_size = p.get_float("filter_size");
  c.min_filter = p.get_float("min_filter");
  c.bias = p.get_float("bias");
  c.subdivide = p.get_int("subdivide");
  c.near_field = p.get_float("near_field");
  return c;
}

MemoryEstimate core_memory(const ParamSet& p, const MemoryQuery& q, int channels) {
  MemoryTally tally;
  const CoreParams c = core_params(p);
  shadow_map::add_map_memory(tally, c.view.resolution, q);
  const ViewSize v = fitted_view_bound(c.view.resolution);
  tally.add(FilteredMomentMap::bytes(v.width, v.height, channels, c.prefilter), "resolution");
  partitions::add_memory(tally, p, q);
  return tally.estimate();
}

std::unique_ptr<ShadowMethod> make_filtered_moment_method(const std::string& name, const ParamSet& p) {
  return partitions::wrap(std::make_unique<FilteredMomentShadows>(p, make_moment_model(name, p)), p,
                          p.get_int("resolution"));
}

FilteredMomentShadows::FilteredMomentShadows(const ParamSet& p, std::unique_ptr<MomentModel> model)
    : params_(core_params(p)), model_(std::move(model)) {}

void FilteredMomentShadows::prepare(const ShadowContext& ctx) {
  stats_.prepare_count++;
  // No shadow reach (LightCentreMap::prepare): the receivers beyond max_fov keep their near
  // field's rays, which on a street seen from one end were exact where the reach's 85-degree map
  // was ten times coarser (docs/methods/vsm.md, "Beyond max_fov").
  map_.prepare(*ctx.scene, *ctx.light, stats_, /*hold_reach=*/false);
  built_from_ = 0;
}

void FilteredMomentShadows::evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) {
  const AreaLight& light = *ctx.light;
  if (!map_.update(light, vs, params_.view, stats_)) {
    std::fill(out.visibility.begin(), out.visibility.end(), 0.0f);
    return;
  }
  const shadow_map::ShadowDepthMap& sm = map_.map();
  if (built_from_ != map_.renders()) {
    ScopedPhase phase(stats_, "prefilter");
    moments_.build(sm.map(), *model_, params_.prefilter);
    built_from_ = map_.renders();
  }
  stats_.memory_bytes = std::max<uint64_t>(stats_.memory_bytes, sm.memory_bytes() + moments_.memory_bytes());
  ScopedPhase phase(stats_, "filter");
  const shader::FmShadeBlock block = shade_block(params_, light, sm.shared());
  const shader::FmMapRef map = moments_.ref();
  const shader::FmModel model = model_->shared();
  const int C = model_->channels();
  std::atomic<uint64_t> lookups{0}, unblocked{0}, near_rays{0};
  // The near field's rays need the Embree scene (a bare context without one: the map alone).
  const bool near_field = ctx.tracer && params_.near_field > 0;
  parallel_for(vs.size(), 1024, [&](size_t begin, size_t end) {
    shader::FmShadeCount count{0, 0};
    // The near fields of this range's view samples, traced as one stream.
    std::vector<ShadowRay> rays;
    std::vector<uint32_t> traced;
    for (size_t k = begin; k < end; ++k) {
      const ViewSample& s = vs.samples[k];
      const bool closed = ctx.scene->objects[s.object].closed;
      const float v = shader::fm_shade(map, model, block, s.p, s.ng, closed, count);
      out.visibility[k] = v;
      const float near = near_field ? shader::fm_near_field_length(block, s.p, s.ng, closed, v) : 0.0f;
      if (near > 0.0f) {
        ShadowRay r = shadow_ray_to(s.p, s.ng, block.map.view.eye);
        r.tfar = std::min(r.tfar, near);
        rays.push_back(r);
        traced.push_back(static_cast<uint32_t>(k));
      }
    }
    if (!rays.empty()) {
      std::vector<float> transmit(rays.size());
      ctx.tracer->transmittance(rays, transmit);
      for (size_t j = 0; j < rays.size(); ++j) out.visibility[traced[j]] *= transmit[j];
      near_rays += rays.size();
    }
    lookups += count.lookups;
    unblocked += count.unblocked;
    if (ctx.progress) ctx.progress->add(end - begin);
  });
  // Texels read: 16 per channel for a summed-area box; for the mip chain's tap grid (4 to 64
  // bilinear taps at one or two levels) 16 per channel is a lower bound.
  stats_.texels_visited += lookups.load() * 16 * C;
  stats_.add_count("filtered_lookups", lookups.load());
  if (params_.blocker_search) stats_.add_count("samples_without_blockers", unblocked.load());
  stats_.add_count("near_field_rays", near_rays.load());
}

}  // namespace penumbra::filtered_moments
