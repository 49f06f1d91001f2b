// The light-space structures of `mlsm` and `mtsm` (xie2007 §4-5): one view from the light's
// centre, pushed back by eq. 4 so that it sees everything any point of the light sees, and
// either a k-layer depth map (MLSM, §4.2) or per-texel compressed transparent layers (MTSM,
// §5.1), each with a min/max quadtree over all of a texel's layers (§4.3).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "penumbra/raster/depth_map.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/raster/minmax_pyramid.h"
#include "penumbra/raster/raster_triangle.h"
#include "penumbra/raster/rasterizer.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/scene/light.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadow/params.h"
#include "penumbra/shadow/partitions/light_partitions.h"
#include "penumbra/shadow/multilayer/transparent_layers.h"

namespace penumbra::multilayer {

struct ViewOptions {
  int resolution = 1024;    // texels along the longer side (square texels)
  float max_fov = 120.0f;   // degrees, as the shadow-map baselines
  bool push_back = true;    // xie2007 eq. 4
};

// What both multilayer methods, on either device, read from their parameter tables
// (multilayer.cpp's specs).
struct MultilayerSettings {
  ViewOptions view;
  bool fit_shadowable = true;
  float z_thresh = 0, z_thresh_texels = 1.0f;
  float self_bias = 0.25f;
  float open_self_bias = 0.1f;
  int layers = 5;                   // mlsm
  bool trace_unresolved = true;     // rays behind a full texel's last layer traced (`unresolved`)
  CompressionOptions compression;   // mtsm
  float stop_below = 1e-3f;         // mtsm
  float near_field = 32.0f;         // narrowest penumbra the map answers for, texels at the receiver
};
MultilayerSettings multilayer_settings(const ParamSet& p, bool transparent);
// Where the light-space partitions (partitions/light_partitions.h) put guard samples for these
// maps: with push-back the fit already holds every receiver-to-light segment beyond the nearest
// caster (light_centre_view), so guards are only needed for a partition that has nothing else to
// fit to; without it, at the blocker-search margin as for the shadow maps.
partitions::GuardSamples partition_guards(const ParamSet& p);

struct CentreView {
  LightView view;
  float push_back = 0;      // d of eq. 4, world units (0 without push-back)
  float half_fov_deg = 0;   // the half angle eq. 4 used
  // Where the trace checks rays against the window: the linear depth beyond which the pushed
  // view was fitted to hold every receiver's segments, when its fit stopped at max_fov
  // (segments_held_beyond); +inf where it did not (every segment held) and without push-back
  // (nothing checked).
  float segments_held_beyond = kInfinity;
};

// xie2007 §6.2, eq. 4: the light-centre view, with the eye pushed back along -n by
// d = light_radius / tan(fov / 2), where fov is the field of view of the view fitted at the
// centre to the receivers: from there the frustum of the same angle contains the whole light,
// so every segment from a receiver to a light point lies inside it (both ends do, and the
// frustum is convex) and no caster that could block such a segment is clipped. The pushed
// view is then fitted to the receivers and the light's outline (so the window keeps the
// whole light inside; fit_shadow_view's near plane stays in front of every caster).
// Without push_back: the view fitted at the centre to the receivers alone.
//
// With `caster_boxes` (the boxes of everything that can shadow, caster_boxes() below), the
// pushed view is fitted tighter: casters lie no nearer than z_c, the boxes' smallest depth in
// that view, so only the parts of the receiver-to-light segments beyond z_c need to be
// inside. For a receiver r those parts project inside the windows of r and of the points where
// the segments from r to the outline's vertices cross depth z_c (the light lies in a plane of
// constant depth, so the crossings of the segments to the whole light are the polygon of those
// points). The light itself may then fall outside the window; no caster does.
CentreView light_centre_view(const AreaLight& light, std::span<const Vec3f> receivers, const Bounds3f& casters,
                             const ViewOptions& options, std::span<const Bounds3f> caster_boxes = {});
// The part of light_centre_view between its two fits, shared with the GPU's fit (which reduces
// the receivers on the device): from the view fitted at the light's centre, the half angle, d of
// eq. 4, the pushed-back eye and its frame, the light's outline (32 points), z_c (the caster
// boxes' smallest depth from the eye; -inf without boxes), and whether the second fit takes the
// segments' crossings of z_c (`crossings`: z_c lies beyond the light) or the outline itself.
struct PushBackPlan {
  Vec3f dir, up;
  ShadowViewFit fit;
  float half_fov_deg = 0;
  float push_back = 0;
  Vec3f eye;
  std::vector<Vec3f> outline;
  float z_c = -kInfinity;
  bool crossings = false;
  ShadowViewFrame frame;
};
PushBackPlan plan_push_back(const AreaLight& light, const LightView& centre, const Bounds3f& casters,
                            const ViewOptions& options, std::span<const Bounds3f> caster_boxes);
// Where the pushed view `view`, fitted from `plan`, may fail to hold a receiver's segments to the
// light: the depth beyond which it was fitted to hold them (where casters stand: z_c with the
// segments' crossings, else the near plane, the outline itself having been fitted just past it),
// when the fit stopped at max_fov on some side; +inf (every segment held) when it did not, and
// without push-back. The trace checks each ray beyond that depth against the window
// (multilayer_trace_shared.h ml_leaves_window).
float segments_held_beyond(const PushBackPlan& plan, const LightView& view, bool push_back);
// The most light_centre_view allocates for `receivers` receivers: the points it fits, each
// receiver and its segments' crossings toward the light's outline (`outline_points`
// vertices).
uint64_t light_centre_view_bytes(uint64_t receivers, uint64_t outline_points);

// An object as caster_boxes weighs it: its box, and for a planar object its plane (dot(n, x) =
// d), the light centre's side of it and the tolerance (multilayer_view_shared.h ml_behind_plane).
// A plane the light does not straddle shadows a receiver only when some receiver lies behind it
// (needs_receiver_behind).
struct CasterCandidate {
  Bounds3f box;
  Vec3f n;
  float d = 0, side = 0, tol = 0;
  bool needs_receiver_behind = false;
};
// Every object with geometry, in object order (the receiver-independent half of caster_boxes).
std::vector<CasterCandidate> caster_candidates(const Scene& scene, const AreaLight& light);

// The bounding boxes of the objects that can shadow some receiver: every object's, less
// planar objects with no receiver behind them (a ground plane shadows nothing above it).
std::vector<Bounds3f> caster_boxes(const Scene& scene, const AreaLight& light, std::span<const Vec3f> receivers);

// The receivers that some caster can shadow (penumbra's addition, so the map's texels go
// where shadows can fall: on the shipped scenes the camera sees an 8 x 8 ground plane whose
// far parts would stretch the view to max_fov). Casters are the objects' bounding boxes,
// less planar objects with no receiver behind them (a ground plane shadows nothing above
// it). A receiver p is kept when some box meets the cone from p to the light, tested
// conservatively in a gnomonic projection around the direction from p to the light's
// centre: the box's corners' window against the light outline's (a box with a corner not in
// front of p keeps p). Returns all receivers when none is kept (a view must still exist).
std::vector<Vec3f> shadowable_receivers(std::span<const Bounds3f> casters, const AreaLight& light,
                                       std::span<const Vec3f> receivers);
// Points (x, y, z per point) and boxes (lo, hi: 6 floats per box) flattened for the shared
// per-receiver test (multilayer_view_shared.h ml_shadowable) and the GPU's buffers.
// For tests (multilayer_gpu.cpp): the fragments the GPU mtsm's next maps have room for at first
// (0: sized from the map), to make its fragment lists outgrow their buffer and render again.
void set_first_gpu_fragment_capacity_for_testing(uint32_t fragments);

std::vector<float> flat_points(std::span<const Vec3f> points);
std::vector<float> flat_boxes(std::span<const Bounds3f> boxes);

// MLSM: k nearest distinct surfaces per texel (raster layered_depth_map) and their quadtree.
// Pyramids are over window depth (affine along a projected segment: the walker's
// contract); z_min is the smallest linear depth in the map.
struct OpaqueLayerMap {
  LayeredDepthMap layers;
  MinMaxPyramid pyramid;
  float z_min = kInfinity;
  size_t memory_bytes() const;
  // What a w x h map of k layers holds, for memory estimates.
  static uint64_t bytes(int w, int h, int k) { return LayeredDepthMap::bytes(w, h, k) + MinMaxPyramid::bytes(w, h); }
};
// unknown_beyond_full: a full texel's range reaches kMlBeyondFullTexel (trace_unresolved's
// pyramid: a ray behind its last layer reaches the texel to be told it is unknown there).
void build_opaque_layer_map(Rasterizer& rasterizer, RasterTriangleView triangles, const LightView& view,
                            int k, OpaqueLayerMap* out, bool unknown_beyond_full = false);

// MTSM: every fragment of each light-centre ray, compressed per texel (§5.1), and its quadtree.
struct TransparentMap {
  TransparentLayerMap layers;
  MinMaxPyramid pyramid;
  float z_min = kInfinity;
  size_t fragments = 0;  // before compression
  size_t memory_bytes() const;
  // The most build_transparent_map holds at once for a w x h map whose texels compress into
  // at most `layers_per_texel` layers (an opaque scene's: resets + 1): the map, and while it
  // is built each texel's own vector (grown by doubling) and the texel ranges.
  static uint64_t build_bytes(int w, int h, int layers_per_texel);
};
// unknown_beyond_full: each texel's truncation is kept and its range reaches kMlBeyondFullTexel
// where fragments were dropped (as build_opaque_layer_map's).
void build_transparent_map(Rasterizer& rasterizer, RasterTriangleView triangles, const LightView& view,
                           const CompressionOptions& options, TransparentMap* out, bool unknown_beyond_full = false);

}  // namespace penumbra::multilayer
