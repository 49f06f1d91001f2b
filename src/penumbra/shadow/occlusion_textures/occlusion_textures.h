// Occlusion textures (eisemann2006): the scene cut into S slices parallel to the light,
// each projected onto its far plane as a binary occlusion texture, pre-filtered so that one
// lookup gives the box-filtered coverage over any kernel (§3.2), combined over slices by
// the probabilistic product of eq. 5. Docs: docs/methods/occlusion-textures.md.
//
// Light frame: the light's centre C, its axes right/up (the rect's sides; for a disk, its
// bounding square) and forward = the emitting normal. The depth of a point is its distance
// from the light plane along forward, z = dot(p - C, forward).
//
// Slicing (§3.4): slice k spans depths [top + k T, top + (k + 1) T], T = (bottom - top) / S,
// where [top, bottom] is the depth range of the casters; with `tiles` > 1, the range of the
// casters each light-space tile of the texture sees (penumbra's addition, issue 34: slices that
// follow the casters in wide scenes, still independent of the camera). Its texture lies on its far
// ("bottom") plane, at depth plane(k) = top + (k + 1) T. One perspective rasterization from
// the centre of projection E = C - d forward (a distance d behind the light, its frustum's
// window exactly the light: Fig. 4-5) writes one bit per slice and texel; d is the largest
// distance for which the frustum still contains every caster (fitted) or a parameter.
//
// Shading a point P (u, v, z) (eq. 4, §3.4-3.5): for each slice k whose plane lies between
// the light and P, the light seen from P cuts plane(k) in a rectangle of size t x size(light),
// t = (z - plane(k)) / z (eq. 4), centred where the segment P-C crosses the plane. Its texel
// footprint is t W d / (plane(k) + d) texels wide (independent of the light's size), and
// one filtered lookup gives the occluded fraction I_k. V = prod_k (1 - w_k I_k) (eq. 5), or
// 1 - sum, or 1 - max (with tiles, each slice's kernel in pieces, one per tile, at each tile's
// own plane: occlusion_shared.h ot_visibility_tiled). The slice containing P is skipped; w_k fades the slice just above P
// in linearly over `fade` slice thicknesses below its plane (self-shadowing, §3.4); a point on an
// open surface also tests its own slice's nearest depths (`own_slice`, penumbra's addition,
// occlusion_shared.h ot_own_slice). On a closed
// object V is then multiplied by the part of the light above the receiver's tangent plane
// (`horizon`, penumbra's addition, as vsm's): the slices cannot show a solid hiding the light
// from its own far side. Near the point, where an occluder's penumbra would be narrower than
// `near_field` texels, one ray toward the light's centre answers instead of the slices
// (penumbra's addition, issue 34: occlusion_shared.h ot_near_field_length, ot_slice_weight).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "penumbra/raster/light_view.h"
#include "penumbra/raster/raster_triangle.h"
#include "penumbra/raster/rasterizer.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadow/params.h"
#include "penumbra/shadow/occlusion_textures/occlusion_shared.h"
#include "penumbra/shadow/occlusion_textures/prefilter.h"
#include "penumbra/shadow/stats.h"
#include "penumbra/shadow/view_samples.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra::occlusion {

enum class Prefilter { Mipmap, NBuffer, Sat };
enum class SatPrecision { UInt32, Double };
enum class Combine { Product, Sum, Max };

Prefilter parse_prefilter(const std::string& s);
SatPrecision parse_sat_precision(const std::string& s);
Combine parse_combine(const std::string& s);
const char* to_string(Prefilter p);
const char* to_string(Combine c);

struct Options {
  int slices = 16;         // S, 1..32
  int resolution = 512;    // texture side, a power of two in [16, 4096]
  Prefilter prefilter = Prefilter::NBuffer;
  SatPrecision sat_precision = SatPrecision::UInt32;
  Combine combine = Combine::Product;
  bool thin_fix = false;   // also fill the next slice farther from the light (§3.4, Fig. 6)
  float fade = 1.0f;       // fade-in length of the slice just above a point, in slice thicknesses
  float open_fade = 0.25f;  // ... above a point on an open surface (occlusion_shared.h ot_slicing)
  float cop_distance = 0;  // d in world units; 0 = fitted to the casters
  bool cull_planar = true; // skip planar objects that cannot shadow anything (ground planes)
  bool cull_back_faces = true;   // closed objects: slice only the faces toward the centre of projection
  bool horizon = true;     // closed receivers: V times the light's part above their tangent plane
  bool own_slice = true;   // open receivers: their own slice's nearest depths tested (ot_own_slice)
  int own_slice_scale = 0; // ... kept at own_slice_scale x resolution texels a side (1, 2 or 4; 0 = fitted,
                           // own_slice_fitted_scale)
  int tiles = 0;           // light-space tiles a side, each sliced over its own casters' depth range; 0 = fitted
  float near_field = 2;    // texels: the near field traced toward the light's centre (ot_near_field_length; 0: none)
};

// The method's parameters (method.cpp's table) as Options.
Options options_from(const ParamSet& p);

// own_slice_scale 0 (fitted): 2 where the casters' triangles outnumber the texture's texels (a
// canopy's leaves smaller than a texel, whose shadow-map test wants finer texels than the
// filtered coverage does), else 1 (the slicing pass keeps the depths, at no extra pass).
int own_slice_fitted_scale(const Options& o, uint64_t caster_triangles);
// The side of the own slice's depths for at most `caster_triangles` casters (0 with own_slice off):
// what the memory estimates size their map and the larger rasterization by.
int own_slice_side(const Options& o, uint64_t caster_triangles);

// The light as a rectangle: a rect light itself, a disk (or a sphere's disk facing
// frame.n) as its bounding square.
struct LightRect {
  Vec3f center, right, up, forward;
  float width = 1, height = 1;  // along right, up
};
LightRect light_rect(const AreaLight& light);

class OcclusionTextures {
 public:
  explicit OcclusionTextures(const Options& options);

  // Slices the scene for `light` and pre-filters the textures. Records the phases
  // "slicing" and "filtering" and the memory in *stats.
  void build(const Scene& scene, const AreaLight& light, MethodStats* stats);
  // What build() decides before it rasterizes (the GPU version's set-up too): the casters (the
  // planar non-casters culled), their depth range, the slices, the centre of projection and the
  // slicing view, and setup().
  void plan(const Scene& scene, const AreaLight& light);
  // V for every view sample (a receiver on a closed object of `scene` times its horizon,
  // occlusion_shared.h ot_horizon); records the phase "shading" and the lookups. With `tracer`
  // (the Embree scene of the same geometry), each point's near field is traced (near_field; the
  // statistic near_field_rays); without, the slices answer for all of it.
  void shade(const Scene& scene, const ViewSamples& samples, std::span<float> visibility, MethodStats* stats,
             const RayTracer* tracer = nullptr) const;
  // V of the slices at one point (no horizon: the point has no surface), and the lookups it made.
  // `open`: p lies on an open surface (the fade-in of open_fade); `near_z`: the depth of a near
  // field left to a ray (occlusion_shared.h ot_near_field_depth; 0: none).
  float visibility(Vec3f p, LookupCounters* counters = nullptr, bool open = false, float near_z = 0) const;
  // The own slice's V at a point on an open surface with geometric normal ng (occlusion_shared.h
  // ot_own_slice; shade() multiplies the slices' V by it): 1 with own_slice off or no casters.
  float own_slice_visibility(Vec3f p, Vec3f ng, float near_z = 0) const;

  // What build() chose (for tests, statistics and the docs).
  bool has_casters() const { return has_casters_; }
  const LightRect& light() const { return light_; }
  const LightView& view() const { return view_; }
  float cop_distance() const { return d_; }
  float top() const { return top_; }
  float thickness() const { return thickness_; }
  int slices() const { return options_.slices; }
  // Slice k's plane over the whole depth range (every tile's with tiles = 1).
  float plane(int k) const { return shader::ot_plane(shader::OtSlicing{top_, thickness_, 0.0f}, k); }
  // Each light-space tile's slices (tiles x tiles, row-major from the texture's top-left corner).
  const std::vector<shader::OtTile>& tiles() const { return tiles_; }
  int tiles_side() const { return tiles_side_; }
  float bottom() const { return bottom_; }
  // The per-point arithmetic's record (occlusion_shared.h OtSetup).
  const shader::OtSetup& setup() const { return setup_; }
  const DepthBinMasks& coverage() const { return masks_; }
  // The slices' nearest depths the own slice tests (DepthBinMasks::nearest; empty with
  // own_slice off): the slicing pass's own at own_slice_scale 1, else a pass of their own over
  // nearest_view().
  const DepthBinMasks& own_slice_depths() const { return own_slice_scale_ == 1 ? masks_ : nearest_; }
  // The scale plan() chose (own_slice_scale, or fitted).
  int own_slice_scale() const { return own_slice_scale_; }
  const LightView& nearest_view() const { return nearest_view_; }
  // Whether plan() chose to test the own slice: own_slice, and some caster is open.
  bool own_slice_active() const { return own_slice_active_; }
  // The bins of the nearest depths' own pass (own_slice_scale > 1): the slicing's, with nearest
  // depths, its tiles own_slice_scale times as many texels a side.
  DepthBins nearest_bins(std::vector<Vec2f>* tile_storage) const;
  // Objects left out as planar non-casters.
  const std::vector<uint32_t>& culled_objects() const { return culled_; }
  // The casters as the GPU rasterizer's per-object flags (gpu/raster/raster_layout_shared.h
  // kRasterObject*, a uint per scene object): the culled objects left out, closed objects culled
  // to their faces toward the centre of projection when cull_back_faces (what build() gathers).
  std::vector<uint32_t> slicing_object_flags(const Scene& scene) const;
  // The slicing pass's depth bins (linear depth from the centre of projection): the slices,
  // per light-space tile when tiles > 1 (their (first, width) pairs written to *tile_storage,
  // which the bins point into).
  DepthBins slicing_bins(std::vector<Vec2f>* tile_storage) const;
  // The pre-filtered mean coverage of slice k over a texel-space rectangle.
  float box(int k, float x0, float y0, float x1, float y1, LookupCounters* counters = nullptr) const;
  size_t texture_bytes() const;
  // What texture_bytes() will be at these options (the coverage masks, the prefilter's tables and
  // the own slice's depths), before anything is built: for at most `caster_triangles` casters
  // (the fitted own_slice_scale; by default the larger).
  static uint64_t texture_bytes(const Options& options, uint64_t caster_triangles = ~uint64_t{0});

 private:
  struct Batch;
  template <class F>
  void shade_batch(const F& filter, Batch& batch, bool open, std::span<float> out, LookupCounters& n) const;
  // `near`: each view sample's near field (ot_near_field_length; empty: none).
  template <class F>
  void shade_with(const F& filter, const Scene& scene, const ViewSamples& samples, std::span<float> visibility,
                  std::span<const float> near, LookupCounters& total) const;
  template <class Fn>
  decltype(auto) dispatch(Fn&& fn) const;
  // V at p through the tiles' pieces when its kernels reach a tile with slices of its own
  // (true; the lookups added to n), else false: the batch's slice-by-slice lookups serve it.
  template <class F>
  bool tiled_point(const F& filter, Vec3f p, bool open, float near_z, float* v, LookupCounters& n) const;
  int fitted_tiles() const;
  void set_tiles(int tiles);
  void fit_tiles(const Scene& scene);

  Options options_;
  LightRect light_;
  bool has_casters_ = false;
  bool own_slice_active_ = false;
  int own_slice_scale_ = 1;
  float d_ = 1, top_ = 0, thickness_ = 1;
  float bottom_ = 0;
  // The per-point arithmetic's record (occlusion_shared.h): the light's frame, the centre of
  // projection, the fade, the combination, the tiles.
  shader::OtSetup setup_{};
  int tiles_side_ = 1;  // the tiles a side build() chose
  std::vector<shader::OtTile> tiles_;
  std::vector<SliceBounds> slice_bounds_;  // each slice's covered texels (tiles > 1: ot_visibility's)
  LightView view_;
  LightView nearest_view_;  // view_ at own_slice_scale x its texels
  std::vector<uint32_t> culled_;
  RasterTriangles triangles_;
  Rasterizer rasterizer_;
  DepthBinMasks masks_;
  DepthBinMasks nearest_;  // own_slice_scale > 1: the nearest depths' own pass
  MipmapFilter mipmap_;
  NBufferFilter nbuffer_;
  SatFilter<uint32_t> sat32_;
  SatFilter<double> sat64_;
};

}  // namespace penumbra::occlusion
