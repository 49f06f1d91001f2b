#include "penumbra/shadow/filtered_moments/filtered_moments.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numbers>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/raster/shadow_view.h"

namespace penumbra::filtered_moments {

void FilteredMomentMap::build(const DepthMap& map, const MomentModel& model, Prefilter prefilter) {
  prefilter_ = prefilter;
  width_ = map.width;
  height_ = map.height;
  const int C = model.channels();
  float lo = kInfinity, hi = -kInfinity;
  for (float z : map.z)
    if (z < kInfinity) {
      lo = std::min(lo, z);
      hi = std::max(hi, z);
    }
  if (!(lo <= hi)) lo = hi = 1.0f;  // empty map: every lookup reads "nothing"
  inv_lo_ = 1.0 / lo;
  // A map of one depth still needs a range (any positive one: its texels are all at kNear).
  const double range = std::max(1.0 / lo - 1.0 / hi, 1e-6 / lo);
  scale_ = (kFar - kNear) / range;
  // Encode every texel (an empty one as depth 1), then prefilter.
  std::vector<float> texels(static_cast<size_t>(map.width) * map.height * C);
  parallel_for(map.z.size(), 4096, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) {
      const float z = map.z[i];
      model.encode(z < kInfinity ? std::clamp(normalize(z), kNear, kFar) : 1.0, &texels[i * C]);
    }
  });
  float outside[4];
  model.encode(1.0, outside);
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

void FilteredMomentMap::mean(double x0, double y0, double x1, double y1, double* out) const {
  // A region reaching past the map's edge is cut to it (the mean of what the map holds there)
  // rather than filled with empty texels: the map is fitted to the receivers, so beyond its
  // edge lie casters it did not keep, not empty space (a crop of the image would otherwise
  // lose the blockers just outside its window).
  const double cx0 = std::max(x0, 0.0), cy0 = std::max(y0, 0.0);
  const double cx1 = std::min(x1, double(width_)), cy1 = std::min(y1, double(height_));
  if (cx1 > cx0 && cy1 > cy0) x0 = cx0, y0 = cy0, x1 = cx1, y1 = cy1;
  if (prefilter_ == Prefilter::Sat) {
    sat_.box_mean(x0, y0, x1, y1, out);
    return;
  }
  mip_.box_mean(static_cast<float>(x0), static_cast<float>(y0), static_cast<float>(x1), static_cast<float>(y1), out);
}

namespace {

// The light's half axes along frame.s and frame.t as a rectangle (light_half_extent's).
Vec2f light_half_axes(const AreaLight& light) {
  const float k = 0.5f * std::sqrt(std::numbers::pi_v<float>);
  switch (light.shape) {
    case LightShape::Rect: return {0.5f * light.size.x, 0.5f * light.size.y};
    case LightShape::Ellipsoid: return {k * light.radii.x, k * light.radii.y};
    default: return {k * light.radius, k * light.radius};
  }
}

}  // namespace

float light_fraction_above(const AreaLight& light, Vec3f p, Vec3f ng) {
  // The signed height over p's tangent plane is affine over the light's rectangle:
  // f(u, v) = f00 + (f10 - f00) u + (f01 - f00) v on the unit square; clip the square to
  // f > 0 (Sutherland-Hodgman against one line) and take the area (shoelace).
  const Vec2f h = light_half_axes(light);
  const Vec3f corner = light.center - light.frame.s * h.x - light.frame.t * h.y;
  const float f00 = dot(ng, corner - p), fu = dot(ng, light.frame.s) * 2 * h.x, fv = dot(ng, light.frame.t) * 2 * h.y;
  const Vec2f square[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  Vec2f poly[5];
  int n = 0;
  auto f = [&](Vec2f q) { return f00 + fu * q.x + fv * q.y; };
  for (int i = 0; i < 4; ++i) {
    const Vec2f a = square[i], b = square[(i + 1) % 4];
    const float fa = f(a), fb = f(b);
    if (fa > 0) poly[n++] = a;
    if ((fa > 0) != (fb > 0)) poly[n++] = a + (b - a) * (fa / (fa - fb));
  }
  float area = 0;
  for (int i = 0; i < n; ++i) area += poly[i].x * poly[(i + 1) % n].y - poly[(i + 1) % n].x * poly[i].y;
  return std::clamp(0.5f * area, 0.0f, 1.0f);
}

Vec2f light_half_extent(const AreaLight& light, const LightView& view) {
  const Vec2f h = light_half_axes(light);
  const Vec3f s = light.frame.s, t = light.frame.t;
  return {std::abs(dot(s, view.right())) * h.x + std::abs(dot(t, view.right())) * h.y,
          std::abs(dot(s, view.up())) * h.x + std::abs(dot(t, view.up())) * h.y};
}

std::vector<ParamSpec> core_param_specs(int default_resolution, Prefilter default_prefilter) {
  return {
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
      {"bias", ParamType::Float, 2e-3, "depth bias, world units of linear depth, subtracted from the receiver's depth",
       {}, 0, 1e30},
  };
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
  return c;
}

MemoryEstimate core_memory(const ParamSet& p, const MemoryQuery& q, int channels) {
  MemoryTally tally;
  const CoreParams c = core_params(p);
  shadow_map::add_map_memory(tally, c.view.resolution, q);
  const ViewSize v = fitted_view_bound(c.view.resolution);
  tally.add(FilteredMomentMap::bytes(v.width, v.height, channels, c.prefilter), "resolution");
  return tally.estimate();
}

FilteredMomentShadows::FilteredMomentShadows(const ParamSet& p, std::unique_ptr<MomentModel> model)
    : params_(core_params(p)), model_(std::move(model)) {}

void FilteredMomentShadows::prepare(const ShadowContext& ctx) {
  stats_.prepare_count++;
  map_.prepare(*ctx.scene, stats_);
  built_from_ = 0;
}

namespace {

// The variance (normalised depth^2) of p's tangent plane over the box of half extents
// (sx, sy) texels around p's texel: 1/z is affine in texel space along a plane, with gradient
// (plane_a, plane_b) / plane_num (ShadowDepthMap::receiver), and so is the normalised depth;
// a linear ramp of slopes g over a box has variance (g_x^2 sx^2 + g_y^2 sy^2) / 3. The
// blocker estimates take it out of the search region's spread: it lies around t, not in
// front of it, and pushed the blockers' depth toward the light (bunny: vsm MAE 0.050 ->
// 0.035).
double receiver_variance(const shadow_map::ShadowDepthMap& sm, const FilteredMomentMap& moments, const ViewSample& s,
                         double sx, double sy) {
  const shadow_map::Receiver rc = sm.receiver(s.p, s.ng, shadow_map::BiasParams{});
  if (rc.plane_num == 0) return 0;
  const double k = moments.depth_per_inverse_depth() / rc.plane_num;
  const double gx = k * rc.plane_a, gy = k * rc.plane_b;
  return (gx * gx * sx * sx + gy * gy * sy * sy) / 3;
}

}  // namespace

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
  const LightView& view = sm.view();
  const float focal = focal_texels(view);
  const Vec2f half = light_half_extent(light, view) * focal;  // texels per unit of (1/z_b - 1/z_p)
  const float z_min = sm.z_min();
  const double min_half = 0.5 * params_.min_filter;
  const int C = model_->channels();
  std::atomic<uint64_t> lookups{0}, unblocked{0};
  parallel_for(vs.size(), 1024, [&](size_t begin, size_t end) {
    uint64_t n = 0, lit = 0;
    double m[4];
    for (size_t k = begin; k < end; ++k) {
      const ViewSample& s = vs.samples[k];
      if (!shadow_map::in_front_of_light(light, s.p)) {
        out.visibility[k] = 0.0f;
        continue;
      }
      // On a closed object the light behind p's own tangent plane is blocked by the object
      // itself (a segment to it runs through the inside: shadow_map_common.h); the rest is
      // what the map decides (pcss drops those light points from its kernels likewise).
      const float horizon = ctx.scene->objects[s.object].closed ? light_fraction_above(light, s.p, s.ng) : 1.0f;
      if (!(horizon > 0)) {
        out.visibility[k] = 0.0f;
        continue;
      }
      const Vec3f tx = view.to_texel(s.p);
      if (!(tx.z >= view.near() && tx.x >= 0 && tx.y >= 0 && tx.x < view.width() && tx.y < view.height())) {
        out.visibility[k] = horizon;  // not covered by the map (beyond max_fov): lit
        continue;
      }
      // Normalised like the texels (a receiver behind every covered depth compares as the
      // farthest one: empty texels, at 1, never block).
      const double t = std::clamp(moments_.normalize(tx.z - params_.bias), 0.0, FilteredMomentMap::kFar);
      double hx = 0.5 * params_.filter_size, hy = hx;
      if (params_.blocker_search) {
        // 1. Blocker search: the light projected through p onto z_min.
        const double search = tx.z > z_min ? 1.0 / z_min - 1.0 / tx.z : 0.0;
        const double sx = std::max<double>(half.x * search, min_half), sy = std::max<double>(half.y * search, min_half);
        moments_.mean(tx.x - sx, tx.y - sy, tx.x + sx, tx.y + sy, m);
        ++n;
        const BlockerEstimate b = model_->blockers(m, t, receiver_variance(sm, moments_, s, sx, sy));
        // A fraction this small is the receiver's own surface in the Chebyshev bound's tail.
        if (!(b.fraction > 1e-4)) {
          out.visibility[k] = horizon;
          ++lit;
          continue;
        }
        // 2. Penumbra estimate: the light's shape scaled by (1/d_b - 1/z_p) (PCSS).
        // No caster lies nearer than the map's nearest one (the estimates can undershoot).
        const double scale =
            std::max(0.0, moments_.inverse_depth(std::max(b.depth, FilteredMomentMap::kNear)) - 1.0 / tx.z);
        hx = half.x * scale;
        hy = half.y * scale;
      }
      hx = std::max(hx, min_half);
      hy = std::max(hy, min_half);
      moments_.mean(tx.x - hx, tx.y - hy, tx.x + hx, tx.y + hy, m);
      ++n;
      out.visibility[k] = horizon * std::clamp(model_->visibility(m, t), 0.0f, 1.0f);
    }
    lookups += n;
    unblocked += lit;
    if (ctx.progress) ctx.progress->add(end - begin);
  });
  // Texels read: 16 per channel for a summed-area box; for the mip chain's tap grid (4 to 64
  // bilinear taps at one or two levels) 16 per channel is a lower bound.
  stats_.texels_visited += lookups.load() * 16 * C;
  stats_.extra["filtered_lookups"] = lookups.load();
  if (params_.blocker_search) stats_.extra["samples_without_blockers"] = unblocked.load();
}

}  // namespace penumbra::filtered_moments
