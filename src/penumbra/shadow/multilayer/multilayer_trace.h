// Tracing shadow rays through the multilayer maps (xie2007 §4.3, §5.2): each segment from a
// receiver to a light point is projected into the light-centre view, clipped to the near
// plane and the image, and walked through the map's min/max quadtree (the shared
// raster/depth_image_walk.h walker, over window depth, which is affine along the projected
// segment); at each texel reached, the layers are tested in linear (camera-space) depth
// against the ray's [z_enter, z_exit] widened by z_thresh (§6.1).
#pragma once

#include <cstdint>
#include <span>

#include "penumbra/core/math.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/shadow/multilayer/multilayer_map.h"
#include "penumbra/shadow/multilayer/multilayer_trace_shared.h"

namespace penumbra::multilayer {

struct TraceParams {
  float z_thresh = 0;        // world units of linear depth (xie2007 §6.1)
  float self_bias = 0.25f;   // texel widths at the receiver: the band around its own tangent plane ignored
  float open_self_bias = 0.1f;  // ... at a receiver on an open surface
  float stop_below = 1e-3f;  // mtsm: a ray whose visibility falls below this is blocked (§5.2 threshold)
  // The narrowest penumbra the map answers for, in texel widths at the receiver: the part of a ray
  // where an occluder's would be narrower is traced through the scene by the caller first
  // (ml_near_fraction; the method's `near_field`); 0: the map answers for the whole ray.
  float near_field = 0;
  float light_width = 0;  // near_field_light_width of the light
};

// The trace parameters with z_thresh resolved for a map (xie2007 §6.1: in camera space): the
// given `z_thresh` when positive, else z_thresh_texels texel widths at the geometric mean of the
// map's nearest depth z_min and its far plane.
TraceParams resolve_trace_params(const TraceParams& params, const LightView& view, float z_min, float z_thresh,
                                 float z_thresh_texels);

// What one map needs precomputed for tracing.
struct TraceSetup {
  const LightView* view = nullptr;
  float z_thresh = 0;
  float window_tolerance = 0;  // z_thresh as a (conservative) window-depth tolerance for node tests
  float inv_focal = 0;         // texel world width per unit of linear depth
  float self_bias = 0.25f;
  float open_self_bias = 0.1f;
  float stop_below = 1e-3f;
  float near_field = 0;
  float light_width = 0;
  // CentreView's: with a near field, a ray whose part beyond this depth leaves the window is traced
  // whole (ml_leaves_window); +inf: none is.
  float segments_held_beyond = kInfinity;
};
// z_min: the map's smallest depth (the widest window-depth span of +-z_thresh is there).
TraceSetup make_trace_setup(const LightView& view, float z_min, const TraceParams& params);
// The set-up as the shared trace functions and the GPU's kernels read it (multilayer_trace_shared.h).
shader::MlTraceSetup shared_trace_setup(const TraceSetup& s, float z_min);

// The receiver of a shadow ray: its position and geometric normal, and whether it lies on a
// closed object (then light points behind its tangent plane are blocked by the object).
struct RayReceiver {
  Vec3f p, ng;
  bool closed = false;
};

struct TraceCounters {
  uint64_t rays = 0;
  uint64_t nodes = 0;          // quadtree nodes tested
  uint64_t texels = 0;         // texels reached (leaf visits)
  uint64_t layers_tested = 0;  // layers compared with a ray in those texels
  uint64_t layer_hits = 0;     // layers (mtsm: estimated samples) that attenuated a ray
  uint64_t unresolved = 0;     // rays the map could not answer for, traced through the scene (mlsm)
  void add(const TraceCounters& o) {
    rays += o.rays;
    nodes += o.nodes;
    texels += o.texels;
    layers_tested += o.layers_tested;
    layer_hits += o.layer_hits;
    unresolved += o.unresolved;
  }
};

// Transmittance of the segment from r.p to light point q: MLSM (§4.3), 0 or 1; kMlUnresolved
// where the map cannot answer (ml_trace_opaque: a map built with unknown_beyond_full).
float trace_opaque(const TraceSetup& setup, const OpaqueLayerMap& map, const RayReceiver& r, Vec3f q,
                   TraceCounters* counters);
// MTSM (§5.2): the product of the per-sample transmittances of the estimated samples the ray
// crosses; 0 once it falls below stop_below. Opaque layers block by the MLSM rule (so on an
// opaque scene this is trace_opaque); semi-transparent samples count where the ray's
// unwidened, half-open depth interval over a texel holds them, so each is counted once.
float trace_transparent(const TraceSetup& setup, const TransparentMap& map, const RayReceiver& r, Vec3f q,
                        TraceCounters* counters);

// The rays from one receiver to the light points q[i], out[i] their transmittance: the
// single-ray traces above, walked in packets (walk_depth_image_packet) so the nodes the rays
// share, from the root down to the receiver's texel, are read and split once per packet. The
// same texels reach the same leaf tests; only trace_transparent's product may differ in its
// last bit, multiplied in another order.
void trace_opaque(const TraceSetup& setup, const OpaqueLayerMap& map, const RayReceiver& r, std::span<const Vec3f> q,
                  float* out, TraceCounters* counters);
void trace_transparent(const TraceSetup& setup, const TransparentMap& map, const RayReceiver& r,
                       std::span<const Vec3f> q, float* out, TraceCounters* counters);

}  // namespace penumbra::multilayer
