// The core the methods `vsm`, `evsm` and `msm` share (docs/methods/vsm.md, msm.md): one
// depth map from the light's centre (shadow/shadow_map_common.h's LightCentreMap:
// the same fitted view and rasterization as shadow-map and pcss), each texel's depth turned
// into a vector of moments by a MomentModel, the vectors prefiltered (raster/filtered_map.h:
// summed-area table or mip chain), and per view sample two filtered lookups:
//
//  1. Blocker search (PCSS's step 1, Fernando 2005, over the region where a blocker can
//     appear: the light's shape projected through the receiver onto the nearest caster's
//     depth z_min): one filtered lookup over that rectangle, and the model's estimate of
//     the fraction in front of the receiver and their mean depth d_b (from the moments:
//     Yang et al. 2010 for VSM/EVSM, Peters et al. 2016 for MSM). None: lit.
//  2. Filter: the light's shape scaled by (1/d_b - 1/z_p) (PCSS's penumbra estimate, the
//     kernel of shadow_map::kernel_offset), one filtered lookup over it, and the model's
//     visibility from those moments (Chebyshev, EVSM, Hamburger 4MSM).
//
// With blocker_search=false the filter is a fixed square of filter_size texels (plain
// prefiltered VSM/EVSM/MSM, the papers' own set-up).
//
// The light's shape as a rectangle: a rect's own sides; a disk, a sphere's disk or an
// ellipse as the rectangle of equal area along its axes (a box filter is what the
// summed-area table gives; docs/methods/vsm.md). Depth is stored as an affine function of
// 1/z (window depth; z the LightView's linear depth) over the map's covered range, mapped to
// [0.05, 0.95] (FilteredMomentMap::normalize); an empty texel holds
// the moments of depth 1 (nothing in front of anything), as does everything outside the map.
// Casters' opacity is ignored (a moment map holds depths, not transmittance).
//
// The per-texel and per-sample arithmetic is filtered_moments_shared.h's and moments_shared.h's,
// which the GPU version (filtered_moments_gpu.cpp) runs too.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "penumbra/raster/depth_map.h"
#include "penumbra/raster/filtered_map.h"
#include "penumbra/shadow/shadow_map_common.h"
#include "penumbra/shadow/filtered_moments/filtered_moments_shared.h"
#include "penumbra/shadow/filtered_moments/moments.h"
#include "penumbra/shadow/shadow_method.h"

namespace penumbra::filtered_moments {

// What a method stores per texel and reads back from a filtered vector.
class MomentModel {
 public:
  virtual ~MomentModel() = default;
  virtual int channels() const = 0;  // 1..4
  // The vector a texel at normalised depth z in [0, 1] stores.
  virtual void encode(double z, float* out) const = 0;
  // V at normalised receiver depth t from the mean vector of a filter region. (Taking the
  // receiver plane's variance out here too, as blockers() does, made the bunny worse: vsm
  // MAE 0.035 -> 0.043, evsm 0.038 -> 0.076: the bound then turns too dark wherever the
  // receiver is curved rather than planar.)
  virtual float visibility(const double* mean, double t) const = 0;
  // The blockers the mean vector of a search region shows in front of t. receiver_variance:
  // the variance (normalised depth^2) the receiver's own tangent plane has over the region,
  // which is no blocker's: the estimate takes it out of the region's spread.
  virtual BlockerEstimate blockers(const double* mean, double t, double receiver_variance) const = 0;
  // The model as the shared functions take it (moments_shared.h).
  virtual shader::FmModel shared() const = 0;
};

enum class Prefilter { Sat, Mipmap };

// A depth map's moments, prefiltered.
class FilteredMomentMap {
 public:
  // Encodes every texel of `map` (its linear depths z) with `model` and prefilters them.
  void build(const DepthMap& map, const MomentModel& model, Prefilter prefilter);
  // Covered depths map to [kNear, kFar], empty texels to 1: inside (0, 1), so that a
  // region of one or two depths mixed with MSM's bias vector (the moments of depths 0 and 1)
  // still has a regular Hankel matrix (Peters & Klein 2015's bias needs distinct points).
  static constexpr double kNear = 0.05, kFar = 0.95;
  // A map of one depth gets a range of kTinyRange / its depth in 1/z.
  static constexpr double kTinyRange = 1e-6;
  // Normalised depth of a linear depth z, and back: affine in 1/z (a hardware depth
  // buffer's window depth, over the map's covered range), so that a planar receiver's depth
  // is affine in texel space and its mean over any region centred on a point is that
  // point's depth. (Linear depth is convex along a tilted plane: over the wide search regions
  // of a light tilted against the ground, its mean lies beyond the centre's depth and the
  // ground under an occluder reads as lit.)
  double normalize(float z) const { return shader::fm_normalize(range_, z); }
  double linear_depth(double d) const { return 1.0 / inverse_depth(d); }
  // 1/z of a normalised depth (what PCSS's penumbra scale 1/d_b - 1/z_p needs).
  double inverse_depth(double d) const { return shader::fm_inverse_depth(range_, d); }
  // d(normalised depth) / d(1/z).
  double depth_per_inverse_depth() const { return -range_.scale; }
  // The mean vector over [x0, x1] x [y0, y1] (texel space) cut to the map: the exact box
  // (summed-area table) or the mip chain's tap grid. A region wholly outside reads empty.
  void mean(double x0, double y0, double x1, double y1, double* out) const;
  // The map as the shared lookups read it (filtered_moments_shared.h).
  shader::FmMapRef ref() const;
  size_t memory_bytes() const { return sat_.memory_bytes() + mip_.memory_bytes(); }
  // What build() allocates at its peak for a w x h map (the encoded texels and the tables).
  static uint64_t bytes(int width, int height, int channels, Prefilter prefilter);

 private:
  Prefilter prefilter_ = Prefilter::Sat;
  int width_ = 0, height_ = 0, channels_ = 1;
  shader::FmDepthRange range_{1, 1, kNear, kFar};
  shader::FilteredChannels outside_{};
  SummedAreaTable sat_;
  MipChain mip_;
};

// The light's shape as a rectangle in a view: half its extent along the view's right and up
// axes, world units (see the header comment).
Vec2f light_half_extent(const AreaLight& light, const LightView& view);

struct CoreParams {
  shadow_map::ViewParams view;
  Prefilter prefilter = Prefilter::Sat;
  bool blocker_search = true;
  float filter_size = 4;  // texels, without the blocker search
  float min_filter = 1;   // texels: the smallest filter side
  float bias = 1e-3f;     // world units of linear depth
  int subdivide = 4;      // most parts a side of the search and filter regions (fm_parts)
  float near_field = 2;   // texels: the light centre's ray traced nearer (fm_near_field_length; 0: none)
};

// The parameter table entries of the core (the light-space partitions' among them), and their values.
std::vector<ParamSpec> core_param_specs(int default_resolution, Prefilter default_prefilter);
CoreParams core_params(const ParamSet& p);
// One instance's memory: the depth map (shadow_map::add_map_memory), the moments and the
// partitions' wrapper.
MemoryEstimate core_memory(const ParamSet& p, const MemoryQuery& q, int channels);
// The method `name` (vsm, evsm, msm) with its parameters: the core with its moment model, split
// into light-space partitions where the casters are dense (partitions::wrap; issue 34).
std::unique_ptr<ShadowMethod> make_filtered_moment_method(const std::string& name, const ParamSet& p);

// What every lookup of the map `map` (its view and z_min) and `light` reads (both devices).
shader::FmShadeBlock shade_block(const CoreParams& params, const AreaLight& light, const shader::ShadowMapView& map);

class FilteredMomentShadows final : public ShadowMethod {
 public:
  FilteredMomentShadows(const ParamSet& p, std::unique_ptr<MomentModel> model);
  void prepare(const ShadowContext& ctx) override;
  void evaluate(const ShadowContext& ctx, const ViewSamples& vs, ShadowOutput& out) override;

 private:
  CoreParams params_;
  std::unique_ptr<MomentModel> model_;
  shadow_map::LightCentreMap map_;
  FilteredMomentMap moments_;
  uint64_t built_from_ = 0;  // map_.renders() the moments were built from
};

}  // namespace penumbra::filtered_moments
