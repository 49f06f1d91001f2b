// The compute rasterizer (docs/raster.md, "The GPU rasterizer"): the CPU rasterizer's depth
// maps (raster/rasterizer.h) rendered on the device from the GpuScene, with the same semantics
// and the same arithmetic (raster/raster_shared.h): triangles in homogeneous texel space clipped
// against near, far and the guard band, snapped to 1/256 texel, exact int64 edge functions with
// the top-left rule, coverage at texel centres, depth from the unsnapped vertices, alpha looked
// up per fragment, the nearest surface per texel with ties to the first triangle in input order
// (object order, then mesh order: gather_raster_triangles' numbering, which the map's triangle
// plane uses). Shared machinery: depth maps, depth-bin masks, layered maps and fragment lists
// (conservative rasterization next) (the kernels are named for their stage:
// gpu/raster/kernels/raster_*.comp; the buffers are gpu/raster/raster_layout_shared.h's).
#pragma once

#include <cstdint>
#include <functional>
#include <string_view>

#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/commands.h"
#include "penumbra/gpu/gpu_scene.h"
#include "penumbra/gpu/raster/gpu_raster_modes.h"
#include "penumbra/gpu/raster/raster_layout_shared.h"
#include "penumbra/gpu/raster/raster_scratch.h"
#include "penumbra/raster/depth_map.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/raster/rasterizer.h"

namespace penumbra::gpu {

// The word the passes clear to: an empty fragment key (both words), an empty z_min.
inline constexpr uint32_t kRasterEmptyWord = 0xffffffffu;

// A depth map on the device: DepthMap's planes (z, window depth, opacity, triangle), one buffer
// each, and the view it was rendered from (its RasterView record, for kernels that look it up).
class GpuDepthMap {
 public:
  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return width_ == 0; }
  const LightView& view() const { return view_; }
  // The smallest linear depth in the map (+inf when it is empty): xie2007's z_min.
  float z_min() const { return z_min_; }

  // Device addresses of the planes (float, float, float, uint per texel, row-major) and of the
  // view's RasterView record (raster/raster_shared.h).
  uint64_t z() const { return z_.address(); }
  uint64_t depth() const { return depth_.address(); }
  uint64_t opacity() const { return opacity_.address(); }
  uint64_t triangle() const { return triangle_.address(); }
  uint64_t view_record() const { return view_record_.address(); }

  // The planes copied back into a DepthMap (tests and tools; a method never reads a map back).
  DepthMap download() const;
  uint64_t device_bytes() const;
  // What a w x h map holds: the keys the fill writes (8 bytes a texel), the four planes and the
  // view record.
  static uint64_t bytes(int w, int h);

 private:
  friend class GpuRasterizer;
  void resize(Device& device, int w, int h);
  int width_ = 0, height_ = 0;
  LightView view_;
  float z_min_ = kInfinity;
  Buffer keys_, z_, depth_, opacity_, triangle_, view_record_;
};

class GpuDepthBinMasks;  // gpu_depth_bins.h

class GpuRasterizer {
 public:
  // Runs what a command list recorded and waits (a GPU method passes GpuFrame::flush, so the
  // frame's GPU times include it; tests pass CommandList::submit).
  using Submit = std::function<void()>;

  explicit GpuRasterizer(Device& device);

  // The nearest surface of every triangle of `scene` through each texel centre of `view`, with
  // its opacity and input triangle index: the CPU's Rasterizer::depth_map. Submits what
  // `commands` holds first (the map's buffers are rewritten from the host), records the four
  // kernels in the GPU stage `stage`, submits them, and reads the counters back (a few bytes):
  // where the set-up triangles or work items outgrew their buffers, it grows them and renders
  // again. `object_flags`: as depth_bin_masks' (0: every object).
  void depth_map(CommandList& commands, const Submit& submit, std::string_view stage, const GpuScene& scene,
                 const LightView& view, const RasterFilter& filter, GpuDepthMap* out, uint64_t object_flags = 0);

  // Which depth bins each texel centre's fragments fall in: the CPU's Rasterizer::depth_bin_masks
  // (eisemann2006 §3.4's slicing pass), the same way as depth_map (gpu_depth_bins.cpp).
  // `object_flags`: the device address of a uint per scene object (kRasterObject* bits of
  // raster_layout_shared.h: objects left out, objects culled to the faces toward the view's eye),
  // or 0 for none.
  void depth_bin_masks(CommandList& commands, const Submit& submit, std::string_view stage, const GpuScene& scene,
                       const LightView& view, const RasterFilter& filter, const DepthBins& bins,
                       uint64_t object_flags, GpuDepthBinMasks* out);

  // The k = options.layers nearest distinct surfaces through each texel centre, nearest first
  // (xie2007 §4.2): the CPU's Rasterizer::layered_depth_map, by peeling (gpu_rasterizer_layers.cpp).
  // Submits, reads back and grows as depth_map does.
  void layered_depth_map(CommandList& commands, const Submit& submit, std::string_view stage, const GpuScene& scene,
                         const LightView& view, const LayerOptions& options, GpuLayeredDepthMap* out,
                         uint64_t object_flags = 0);

  // Every fragment through each texel centre with its opacity, each texel's sorted by depth
  // (xie2007 §5): the CPU's Rasterizer::fragment_lists (gpu_rasterizer_layers.cpp). The fragments
  // buffer grows to the total the counting pass found, and the lists render again.
  void fragment_lists(CommandList& commands, const Submit& submit, std::string_view stage, const GpuScene& scene,
                      const LightView& view, const RasterFilter& filter, GpuFragmentLists* out,
                      uint64_t object_flags = 0);

  // The last call's counts (RasterStats; no times: those are the GPU stages') and how many
  // renders it took (1 unless a buffer grew).
  const RasterStats& stats() const { return stats_; }
  int attempts() const { return attempts_; }

  // The scratch a GpuRasterizer allocates for `triangles` triangles and a width x height map at
  // first (what the memory estimates count): set-up triangles for every input triangle and an
  // eighth more (fans of clipped ones), work items for two tiles a triangle and two triangles a
  // tile (a ground plane), the counters.
  static uint64_t scratch_bytes(uint64_t triangles, int width, int height);

  // For tests: the capacities of the next render (0: sized from the scene and the map), to make
  // it outgrow its buffers and retry.
  void set_capacities_for_testing(uint32_t triangles, uint32_t items);
  // For tests: the fragments the next fragment_lists call has room for at first.
  void set_fragment_capacity_for_testing(uint32_t fragments) { fragment_capacity_for_testing_ = fragments; }

 private:
  // Records the passes of one mode's fill and resolve, given the fill's parameters (all but
  // `keys`, the mode's output).
  using RecordFill = std::function<void(const shader::RasterFillParams&)>;
  // What every mode runs: set-up (with the filter and the per-object flags), the fill's indirect
  // arguments, the mode's fill and resolve (`fill`), then submits and reads the counters back;
  // grows the buffers and renders again where they overflowed. The counters of the render that
  // fitted (also in stats()).
  shader::GpuRasterState render_passes(CommandList& commands, const Submit& submit, std::string_view stage,
                                       const GpuScene& scene, const LightView& view, uint64_t view_record,
                                       const RasterFilter& filter, uint64_t object_flags, const RecordFill& fill);
  uint32_t fragment_capacity_for_testing_ = 0;
  Device* device_;
  Buffer state_;
  Buffer tile_bins_;  // depth_bin_masks' bins per tile (DepthBins::tiles)
  RasterScratch scratch_;
  RasterStats stats_;
  int attempts_ = 0;
};

}  // namespace penumbra::gpu
