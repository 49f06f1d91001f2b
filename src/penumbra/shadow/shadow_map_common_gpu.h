// What the shadow-map methods share on the GPU (`shadow-map`, `pcss`; shadow_map_common.h's
// LightCentreMap on the device): the map from the light's centre fitted to the receivers of the
// view samples, re-rendered only when the fitted view changes. The fit reduces the receivers on
// the device (shadow/kernels/shadow_fit_receivers.comp) to 32 bytes the host reads back
// (GpuFrame::flush) and builds the view from with the CPU's code (build_shadow_view), so the view
// equals the CPU's up to float rounding; the map is the GPU rasterizer's (gpu/raster/).
#pragma once

#include <optional>

#include "penumbra/gpu/raster/gpu_rasterizer.h"
#include "penumbra/gpu/raster/object_culling.h"
#include "penumbra/raster/shadow_view.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/shadow_map_common.h"
#include "penumbra/shadow/shadow_map_kernels_shared.h"

namespace penumbra::shadow_map {

// The view fitted to the receivers a fit kernel reduced into `r` (frame: the view's frame, as
// shadow_view_frame gave it): build_shadow_view of the range's floats, the CPU's view up to float
// rounding. Throws as fit_shadow_view does when no receiver lies beyond min_near.
LightView view_from_range(const ShadowViewFrame& frame, const shader::GpuReceiverRange& r, const Bounds3f& casters,
                          const ShadowViewFit& fit);
// The range's floats (empty where no receiver was fitted).
ShadowViewRange range_floats(const shader::GpuReceiverRange& r);
// What a fit kernel's range starts from: no receiver, the identities of min and max.
shader::GpuReceiverRange empty_receiver_range();
// The receivers of frame.view_samples (hits in front of the light) reduced on the device into
// `range` (a GpuReceiverRange buffer) in the frame `axes`, read back after frame.flush().
shader::GpuReceiverRange reduce_receivers(const AreaLight& light, GpuFrame& frame, const ShadowViewFrame& axes,
                                          gpu::Buffer& range);
// The fitted view from the light's centre along its normal (stage "fit"): the receivers of
// frame.view_samples reduced on the device into `range` (a GpuReceiverRange buffer), read back
// after frame.flush(), the view built by the CPU's code (build_shadow_view; `casters`: the
// casters' bounds; `reach`: shadow_reach, the receivers beyond max_fov the window holds too).
// Empty when no view sample is in front of the light.
std::optional<LightView> fit_light_centre_view(const ShadowContext& ctx, GpuFrame& frame, const ViewParams& params,
                                               const Bounds3f& casters, const ShadowRegion& reach, gpu::Buffer& range);

class GpuLightCentreMap {
 public:
  // The casters' bounds (the scene's) and, with hold_reach, the light's shadow reach
  // (LightCentreMap::prepare); call again when the geometry or the light changes.
  void prepare(const ShadowContext& ctx, GpuFrame& frame, bool hold_reach = true);
  // Makes the map serve frame.view_samples (stage "fit"; "raster" when it renders), uploading
  // the view and `bias` (the method's, the same at every call) for the lookups (block()). False
  // if no view sample is in front of the light (there is nothing to look up then; every V is 0).
  bool update(const ShadowContext& ctx, GpuFrame& frame, const ViewParams& view, const BiasParams& bias,
              MethodStats& stats);

  const gpu::GpuDepthMap& map() const { return map_; }
  uint64_t renders() const { return renders_; }

  // What a lookup kernel reads and writes (ShadowMapInputs): the view samples, where V goes, the
  // map's planes and block (the current view and the bias), and the counters. The counters
  // start from 0 at the first lookup after collect() and add up over the frames until then.
  shader::ShadowMapInputs lookup_inputs(gpu::CommandList& commands, const GpuFrame& frame,
                                        const GpuShadowOutput& out, bool has_map);
  // Once the frame has run: the texels read and the receivers outside the map into `stats`
  // (MethodStats::texels_visited, extra receivers_outside_map), and the counters for the rest;
  // nothing (zeros) when no lookup ran since the last call.
  shader::GpuShadowMapCounters collect(MethodStats& stats);

  // One light's device memory at these parameters: the map (a resolution^2 bound), the
  // rasterizer's scratch, the fit's and the lookups' few bytes.
  static void add_memory(MemoryTally& tally, int resolution, const MemoryQuery& q);

 private:
  Bounds3f casters_;
  ShadowRegion reach_;  // shadow_reach
  gpu::ObjectCulling culling_;  // the objects wholly outside the fitted view are not rasterized
  std::unique_ptr<gpu::GpuRasterizer> rasterizer_;
  gpu::GpuDepthMap map_;
  gpu::Buffer range_, block_, counters_;
  bool counting_ = false;  // a lookup ran since the last collect()
  bool valid_ = false;
  uint64_t renders_ = 0;
};

}  // namespace penumbra::shadow_map
