// Shadow rays traced through reference depth images (agrawala2000 §5.1, procedure Trace
// and its accelerations §5.1.1-5.1.2), over the shared hierarchical walk
// (raster/depth_image_walk.h). A ray from a surface point p to a light point q is projected
// into each reference image as an epipolar segment; the walk descends the image's min/max
// quadtree and the leaf test intersects the floors and walls (reference_images.h).
//
// Accelerations, each switchable (TraceOptions):
// - min/max clipping of the segment at every level of the walk (§5.1.1);
// - hierarchical connectedness (§5.1.1): "blocked" at an inner node whose texels form one
//   connected surface that the ray passes from in front of to behind, without descending;
//   gives no blocker point, so it is off when the caller needs one (§5.2.2);
// - clear miss (§5.1.2): a map in which the ray never passes behind a surface proves it
//   unblocked; later maps are not walked;
// - occlusion intervals (§5.1.2): later maps walk only the parts of the ray that were
//   behind surfaces in every earlier map (they end the ray, unblocked, once none is left);
// - ranking (§5.1.2, after Chang): maps in increasing order of the clipped epipolar
//   segment's length.
// A ray reports "blocked" as soon as one map finds an intersection; a ray that passes
// behind surfaces in every map without an intersection is unblocked (§5.1.2).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "penumbra/raster/depth_image_walk.h"
#include "penumbra/shadow/coherent_rt/depth_image_trace_shared.h"
#include "penumbra/shadow/coherent_rt/reference_images.h"

namespace penumbra::coherent_rt {

struct TraceOptions {
  bool minmax_clipping = true;
  bool connectedness = true;
  bool clear_miss = true;
  bool occlusion_intervals = true;
  bool ranking = true;
  // A ray whose occlusion intervals survive every map without an intersection (hidden
  // behind surfaces in all of them): unblocked as in the paper (false), or blocked.
  bool hidden_blocks = false;
  shader::CrtTraceOptions shared() const;
};

struct TraceCounters {
  uint64_t rays = 0;
  uint64_t blocked = 0;
  uint64_t maps_walked = 0;          // sum over rays of the maps walked
  uint64_t clear_misses = 0;         // rays ended by a map that saw all of them (§5.1.2)
  uint64_t intervals_exhausted = 0;  // rays ended when no occlusion interval was left
  uint64_t connected_hits = 0;       // rays blocked at an inner node (connectedness)
  uint64_t hidden_everywhere = 0;    // rays with parts hidden in every map, no intersection
  DepthWalkCounters walk;
  void add(const TraceCounters& o);
};

struct TraceResult {
  bool blocked = false;
  bool has_point = false;  // false for a connectedness hit
  Vec3f point;             // the blocker point on the ray
};

// Per-thread scratch (no allocation per ray once warm): the occlusion spans (a, b).
struct TraceScratch {
  std::vector<Vec2f> intervals, next, walked;
};

class DepthImageTracer {
 public:
  DepthImageTracer() = default;
  DepthImageTracer(std::span<const ReferenceImage> images, const TraceOptions& options);

  // Whether the segment from p to q is blocked by the surfaces of the reference images
// (depth_image_trace_shared.h's crt_trace, which the GPU runs too).
  // need_point: the caller wants the blocker point (connectedness is then not used).
  TraceResult trace(Vec3f p, Vec3f q, bool need_point, TraceScratch& scratch, TraceCounters* counters) const;

  const TraceOptions& options() const { return options_; }
  std::span<const ReferenceImage> images() const { return images_; }

 private:
  std::span<const ReferenceImage> images_;
  std::vector<shader::DepthPyramidLevels> levels_;  // each image's pyramid as the shared walk reads it
  TraceOptions options_;
};

}  // namespace penumbra::coherent_rt
