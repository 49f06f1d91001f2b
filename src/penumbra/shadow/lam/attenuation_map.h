// Layered attenuation maps (agrawala2000 §4): the data structure, its precomputation and
// its lookup. The method `lam` (lam.cpp) drives them; tests and benchmarks use them directly.
//
// Geometry (docs/methods/lam.md):
// - The *reference view* looks from the light centre along the light normal (LightView
//   conventions). Image-plane coordinates (u, v) = (x / z, y / z) at unit depth.
// - Light samples lie in the light's plane (rect, disk; a sphere light is sampled on the disk
//   through its centre facing the scene), and every sample view has the reference view's
//   orientation and texel size, so the warp of a pixel at linear depth z from the view at
//   sample offset d = (dx, dy) (in the light plane, along the view's right/up axes) into
//   the reference view is eq. 3: u_ref = u_sample + dx / z, v_ref = v_sample + dy / z (the
//   disparity is -d / z for a move of the eye by -d), and z itself is unchanged. This is exact (the general projective warp reduces to it).
// - The reference view covers only the *shadow region*: the image-plane window of every
//   object that can shadow something, grown by the light's extent over its nearest depth
//   (eq. 3 with |d| at most the light's half-size): outside it no light sample is blocked,
//   so V = 1 there without a lookup.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/core/sampling.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/raster/raster_triangle.h"
#include "penumbra/shadow/lam/lam_shared.h"
#include "penumbra/shadow/shadow_region.h"
#include "penumbra/shadow/params.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/shadow/view_samples.h"

namespace penumbra {

struct Scene;
struct AreaLight;

namespace lam {

// The tolerance within which two linear depths are one surface: epsilon * z (relative).
inline float depth_tolerance(float epsilon, float z) { return epsilon * z; }

// What the map multiplies epsilon and open_epsilon by, from its reference view's width at unit
// depth (its window over its near plane, the longer side). Relative to z, the tolerance suits a
// light near what it shadows, whose view is about as wide as it is deep. A view narrower than
// kFullToleranceWidth (a light far from the scene: a sun) sees the scene's depth range as a small
// part of z, and epsilon z would span whole objects (a 1 m box under a light 1 km away, 5 m):
// there the tolerance shrinks with the view, to the same size in texels as that of a view
// kFullToleranceWidth wide.
inline constexpr float kFullToleranceWidth = 2.0f;  // a 90-degree view
inline float depth_tolerance_scale(float view_width) { return std::min(1.0f, view_width / kFullToleranceWidth); }
// A relative tolerance times that scale, but not below two float roundings of z (2^-22): depths
// carry that much, and a tolerance under it cannot tell a surface from itself (a light 10^6 away
// over a 1 m box: 0.057 mean |dV| without the floor, 0.002 with it). Never above the tolerance
// asked for (epsilon = 0 stays 0).
inline constexpr float kMinRelativeTolerance = 0x1p-22f;
inline float scaled_depth_tolerance(float epsilon, float scale) {
  return std::min(epsilon, std::max(epsilon * scale, kMinRelativeTolerance));
}

// One layer of one texel after precomputation.
struct Layer {
  float z = 0;            // linear depth in the reference view (mean of the samples that saw it)
  float attenuation = 0;  // fraction of the light samples that see this surface at this texel
};

enum class Filter { Nearest, Bilinear };

// What a display lookup found (exposed for tests and the docs' visualisation).
enum class LookupClass : uint8_t { Match, Occluded, Undefined };

// The layered attenuation map: per texel of the reference view, the distinct surfaces seen
// from at least one light sample, nearest first, each with its attenuation. Flat storage:
// texel i's layers are layers[offsets[i] .. offsets[i + 1]).
class AttenuationMap {
 public:
  AttenuationMap() = default;

  bool empty() const { return width_ == 0; }
  int width() const { return width_; }
  int height() const { return height_; }
  const LightView& view() const { return view_; }
  float epsilon() const { return epsilon_; }
  float open_epsilon() const { return open_epsilon_; }
  int samples() const { return samples_; }
  std::span<const Layer> layers(int x, int y) const {
    size_t i = static_cast<size_t>(y) * width_ + x;
    return {layers_.data() + offsets_[i], offsets_[i + 1] - offsets_[i]};
  }
  size_t layer_count() const { return layers_.size(); }
  // The frame and the light as the display's shared functions read them (lam_shared.h), and the
  // light's outline (at most kMaxOutline points): what the GPU's display uploads.
  const shader::LamMapView& shared() const { return shared_; }
  std::span<const Vec3f> outline() const { return outline_; }
  size_t memory_bytes() const { return offsets_.size() * sizeof(uint32_t) + layers_.size() * sizeof(Layer); }

  // Visibility of world point p with geometric normal n (agrawala2000 §4, Display):
  // project into the reference view; per texel, the layer within epsilon of p's depth gives
  // its attenuation (with slope correction, p's depth is first carried along the plane
  // through p with normal n to the texel's centre, where the layers' depths are; n = 0
  // skips that); no
  // matching layer but one in front: umbra (0); no layer in front either (p was not seen
  // by any sample, nor anything in front of it: thin or grazing geometry): lit (1).
  // Bilinear weighs the 4 texels around p, skipping those without a layer at or in front
  // of p (p's surface does not reach them). Outside the shadow region: 1. *texels (if
  // given) is increased by the number of texels read. The tolerance is epsilon's (a closed
  // object's); the run of view samples below picks open_epsilon for open ones (lam_epsilon).
  float visibility(Vec3f p, Vec3f n, Filter filter, uint64_t* texels = nullptr) const;
  // The display's answer where its texels do not resolve a point (lam_shared.h lam_visibility):
  // with `unresolved` on, shader::kLamUnresolved (< 0) where not all of the point's texels hold
  // its surface or their attenuations differ by more than `trace_spread`, for the caller to trace
  // (lam.cpp); off (the default), the paper's umbra and lit. A display option, not part of the
  // map: write() and read() leave it out.
  void set_unresolved(bool unresolved, float trace_spread) {
    unresolved_ = unresolved;
    trace_spread_ = trace_spread;
    shared_.unresolved = unresolved ? 1u : 0u;
    shared_.trace_spread = trace_spread;
  }
  // The same for a run of view samples (p and ng): out[i] for samples[i]; on a solid object
  // (BuildOptions::solid_objects) V is also at most front_fraction(p, ng).
  void visibility(std::span<const ViewSample> samples, std::span<float> out, Filter filter,
                  uint64_t* texels = nullptr) const;

  // The fraction of the light's area in front of the plane through p with unit normal n (1
  // for n = 0). On a closed mesh the solid lies behind that plane, so the light behind it is
  // hidden; the LDI alone can miss that within epsilon of a lit surface (the unlit side of a
  // box just below its lit top edge, a terminator). Thin open surfaces (two-sided leaves)
  // see the light from both sides, as the reference's rays do, so they are not clamped.
  float front_fraction(Vec3f p, Vec3f n) const;

  // The texel-level classification of a depth at texel (x, y), for tests and images.
  LookupClass classify(int x, int y, float z, float* attenuation) const;

  // The whole map as a binary record (the map cache: `lam` under --map-cache, lam.cpp) and
  // back. The layout is this build's own (the cache keys entries by the program). read()
  // returns false, leaving the map empty, on a short or inconsistent record.
  void write(std::ostream& out) const;
  bool read(std::istream& in);

 private:
  friend class Builder;
  static constexpr int kMaxOutline = shader::kLamMaxOutline;  // disk and sphere lights as 16-gons
  std::vector<Vec3f> outline_;
  Vec3f light_center_, light_normal_{0, 0, 1};
  float light_area_ = 1, light_radius_ = 0;
  std::vector<bool> solid_;  // per scene object: closed mesh
  bool unresolved_ = false;   // set_unresolved
  float trace_spread_ = 1.0f;
  float cap_tan_ = 0;  // ShadowRegion::cap_tan: > 0 where the region was cut (lam_beyond_cap)
  template <bool kBilinear, bool kSlope>
  float visibility_impl(Vec3f p, Vec3f n, bool closed, uint64_t& texels) const;
  template <bool kBilinear, bool kSlope>
  void visibility_batch(std::span<const ViewSample> samples, std::span<float> out, uint64_t* texels) const;
  int width_ = 0, height_ = 0;
  int samples_ = 0;
  float epsilon_ = 0.01f;
  float open_epsilon_ = 0.01f;
  LightView view_;
  // Texel projection rows (p - eye -> (X z, Y z, z)), copied out of the view for speed.
  float proj_[3][4] = {};
  float near_ = 0, far_ = 0;
  // Slope correction: the view's axes and window (u0 left, v1 top, delta per texel).
  bool slope_ = true;
  Vec3f eye_, right_, up_, forward_;
  float u0_ = 0, v1_ = 0, delta_ = 1;
  std::vector<uint32_t> offsets_;  // width * height + 1
  std::vector<Layer> layers_;
  // The members above as lam_shared.h's functions take them (update_shared() after a change).
  void update_shared();
  shader::LamMapView shared_{};
};
static_assert(sizeof(Layer) == 2 * sizeof(float), "lam_shared.h reads the layers as (z, attenuation) floats");

struct BuildOptions {
  int resolution = 512;   // texels along the longer side of the reference view (square texels)
  float epsilon = 0.005f;  // depth tolerance, relative to linear depth
  // ... for open surfaces (objects that are not closed: leaves, cards, planes) with local planes
  // (lam_shared.h lam_epsilon); without them every surface gets epsilon
  float open_epsilon = 0.002f;
  int max_layers = 32;    // layers one texel can hold while building (more are dropped)
  // Compare depths at texel centres: each splat carries its depth to the centres it lands
  // on along the surface's local plane (gradient from the depth map), and a lookup carries
  // the view sample's depth along its own plane. Without it (the paper's rule) a depth is
  // compared as is, which needs epsilon to cover the depth change across a texel or two
  // (insufficient depth sampling on oblique surfaces, agrawala2000 §6.1).
  bool slope = true;
  // With local planes: a splat of an open surface adds its share of the texel (its bilinear
  // weight times the texels its pixel covers) instead of counting the texel once per light
  // sample (lam_shared.h, "Counting a layer"); false: the paper's count for every surface.
  bool weighted_splats = true;
  // Per scene object (RasterTriangle::object, ViewSample::object): whether it is a closed
  // mesh (SceneObject::closed), whose view samples are clamped by front_fraction.
  std::vector<bool> solid_objects;
};

struct BuildStats {
  double fit_ms = 0, raster_ms = 0, warp_ms = 0, insert_ms = 0, finalize_ms = 0;
  size_t sample_texels = 0;  // depth-map texels rendered, all samples
  size_t splats = 0;         // (texel, depth) insertions attempted
  size_t dropped = 0;        // insertions lost to max_layers
  size_t nonempty_texels = 0;
  size_t layers = 0;
  int max_depth = 0;                 // most layers in one texel
  size_t peak_bytes = 0;             // build-time buffers (what the precompute holds at once)
  // Average depth complexity over non-empty texels after k light samples, k = 1..N
  // (agrawala2000 Fig. 10 right).
  std::vector<std::pair<int, double>> depth_complexity;
};

// Precomputation (agrawala2000 §4, procedure Precompute): one depth map per light sample
// `light_samples[i]` (points of [0,1)^2 mapped by AreaLight::sample_area), each pixel warped
// into the reference view by eq. 3 and splatted into its 4 neighbouring texels; a texel's
// layer is counted at most once per light sample; attenuation = count / N.
// The result depends only on its inputs, not on the thread count.
AttenuationMap build_attenuation_map(RasterTriangleView triangles, const AreaLight& light,
                                     const ShadowRegion& region, std::span<const Vec2f> light_samples,
                                     const BuildOptions& options, BuildStats* stats = nullptr);

// The method's parameters (lam.cpp's table: resolution, epsilon, max_layers, local_planes, filter),
// for its CPU and GPU versions.
BuildOptions build_options(const ParamSet& p);
Filter display_filter(const ParamSet& p);
// What `options` needs of the scene at prepare: with local planes, which objects are solid.
BuildOptions options_for_scene(BuildOptions options, const Scene& scene);
// The light samples of the light ctx.light_index (agrawala2000 §3: the same stratified, jittered
// samples for every surface point, banding rather than noise): max(1, ctx.light_samples) of them.
LightSampleSet light_sample_set(const ShadowContext& ctx);
// Those samples as points on the light (AreaLight::sample_area): the sample views' eyes, and the
// points the display traces toward where the LDI does not resolve a view sample.
std::vector<Vec3f> light_points(const AreaLight& light, const LightSampleSet& set);

// The map build_attenuation_map would return before any layer: its reference view, the light's
// outline, the parameters (checked as build_attenuation_map checks them). The GPU builds the
// layers on the device into this frame (lam_gpu.cpp).
AttenuationMap attenuation_map_frame(const AreaLight& light, const ShadowRegion& region, int light_samples,
                                     const BuildOptions& options);

// Per scene object: +1 for a closed mesh wound outward, -1 inward (its signed volume), 0 for any
// other (whose triangles are all kept): the triangles of a closed mesh that face away from every
// point of the light are never the nearest surface seen from a light sample, so a sample's depth
// map is the same without them (lam.cpp).
std::vector<float> closed_mesh_orientations(const Scene& scene);

// What a build reports (lam.cpp's stats.extra, on both devices): light_samples, depth_complexity
// (per sample count), ldi (width, height, layers, nonempty_texels, max_depth,
// dropped_insertions, `ldi_bytes` as bytes, window_degrees), sample_texels, splats.
nlohmann::json build_statistics(const BuildStats& bs, const AttenuationMap& map, int light_samples,
                                uint64_t ldi_bytes);

// The most build_attenuation_map holds at once (for memory estimates) at this resolution
// (the LDI's view is at most resolution^2 texels) and max_layers: the slots of every texel's
// layers while building (allocated whole), one sample view's depth map, splats and binned
// splats (a sample view is the LDI's widened by the light's disparity: at most
// sample_view_side_bound texels a side), and the finished map (at most every slot used).
// The rasterizer's scratch for the sample views comes on top.
uint64_t build_bytes(int resolution, int max_layers);
int sample_view_side_bound(int resolution);

// The reference view for a region at a given resolution (the LDI's view), and a light
// sample's view (eye at `sample`, same axes and texel size, window widened so every point
// of the region at depth in [near, far] is inside). *offset receives the sample view's
// texel-space origin relative to the reference view's, in whole texels.
LightView reference_view(const LightAxes& axes, const ShadowRegion& region, int resolution);
LightView sample_view(const LightAxes& axes, const LightView& reference, Vec3f sample, int* offset_x,
                      int* offset_y);

// Eq. 3 in texel units: a pixel at texel-space point (x, y) and linear depth z in the view of
// a sample displaced by (dx, dy) (world units along right/up) lands at this texel-space
// point of the reference view.
inline Vec2f warp_to_reference(Vec2f texel, float z, float dx, float dy, int offset_x, int offset_y,
                               float texel_size) {
  return {texel.x + offset_x + dx / (z * texel_size), texel.y + offset_y - dy / (z * texel_size)};
}

}  // namespace lam
}  // namespace penumbra
