// The GPU rasterizer's batch mode (docs/raster.md, "Many views at once"): the depth maps of many
// views of one scene rendered in one pass of the rasterizer's stages, each the map
// GpuRasterizer::depth_map (and the CPU's Rasterizer::depth_map) renders from that view, texel for
// texel. What methods with one map per light sample use (`multi-view-sm`, `lam`): hundreds of
// small maps, each too small to fill a GPU alone. The buffers are
// gpu/raster/raster_batch_layout_shared.h's; the kernels gpu/raster/kernels/raster_batch_*.comp.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/commands.h"
#include "penumbra/gpu/gpu_scene.h"
#include "penumbra/gpu/raster/gpu_rasterizer.h"
#include "penumbra/gpu/raster/raster_scratch.h"
#include "penumbra/raster/depth_map.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/raster/rasterizer.h"

namespace penumbra::gpu {

// The maps of one batch of views on the device: one uint64 key per texel of every view
// (raster_depth_key; ~0 where empty) and, when resolved, the z and opacity planes (float per
// texel, DepthMap's). View i's texels start at first_texel(i), row-major.
class GpuDepthMapBatch {
 public:
  int count() const { return static_cast<int>(views_.size()); }
  const LightView& view(int i) const { return views_[i]; }
  uint64_t first_texel(int i) const { return first_[i]; }
  uint64_t texels() const { return texels_; }
  bool resolved() const { return resolved_; }

  // Device addresses: GpuRasterBatchView[count()], the keys, and the planes (0 unless resolved).
  uint64_t views() const { return views_buffer_.address(); }
  uint64_t keys() const { return keys_.address(); }
  uint64_t z() const { return resolved_ ? z_.address() : 0; }
  uint64_t opacity() const { return resolved_ ? opacity_.address() : 0; }

  // View i's map copied back (z from the keys; opacity where resolved, else 0; triangle from the
  // keys; window depth left empty): tests and tools.
  DepthMap download(int i) const;
  uint64_t device_bytes() const;
  // What a batch of `texels` texels over `views` views holds: the keys, the planes where
  // resolved, the view records.
  static uint64_t bytes(uint64_t texels, uint64_t views, bool resolve);

 private:
  friend class GpuBatchRasterizer;
  std::vector<LightView> views_;
  std::vector<uint64_t> first_;
  uint64_t texels_ = 0;
  bool resolved_ = false;
  Buffer views_buffer_, keys_, z_, opacity_;
};

// What the batch set-up may skip beyond RasterFilter: the triangles of closed objects that face
// away from every point of `outline` (an area light's; lam.cpp cull_hidden_back_faces).
// `orientation` has one value per scene object: +1 a closed mesh wound outward, -1 inward, 0 keep.
struct RasterOutlineCull {
  std::vector<float> orientation;
  std::vector<Vec3f> outline;
};

// Per-view caster culling (issue 34 part 3): a uint per (view, object), view-major, `objects`
// a view, with kRasterObjectSkip for the objects a view leaves out (ObjectCulling::
// flags_for_views: those wholly outside its frustum). Kept objects are rasterized whole, so every
// map is the one all objects give.
struct RasterViewCulling {
  std::vector<uint32_t> flags;
  uint32_t objects = 0;
};

class GpuBatchRasterizer {
 public:
  using Submit = GpuRasterizer::Submit;

  explicit GpuBatchRasterizer(Device& device);

  // The maps of `views` into `out` (every view's map is GpuRasterizer::depth_map's from it):
  // submits what `commands` holds first, records the stages in GPU stage `stage`, submits, reads
  // the counters back and, where the set-up triangles or work items outgrew their buffers, grows
  // them and renders the batch again (never drops work). `resolve`: also the z and opacity
  // planes. `cull` (optional): RasterOutlineCull; `view_culling` (optional): the views' own
  // RasterViewCulling, `views.size()` rows. The batch's buffers are reused when the next batch
  // fits in them.
  void depth_maps(CommandList& commands, const Submit& submit, std::string_view stage, const GpuScene& scene,
                  std::span<const LightView> views, const RasterFilter& filter, bool resolve, GpuDepthMapBatch* out,
                  const RasterOutlineCull* cull = nullptr, const RasterViewCulling* view_culling = nullptr);

  // The last call's counts (summed over its views) and how many renders it took.
  const RasterStats& stats() const { return stats_; }
  int attempts() const { return attempts_; }
  // The batch's scratch now (set-up triangles, work items, counters, the culling's arrays).
  uint64_t scratch_device_bytes() const;

  // The scratch the first render of a batch of `views` views of `texels` texels in all allocates
  // for `triangles` scene triangles (what memory estimates count).
  static uint64_t scratch_bytes(uint64_t triangles, uint64_t views, uint64_t texels);
  // How many views of at most `texels_per_view` texels a batch should hold so that its maps and
  // scratch stay within `budget` bytes (at least 1, at most `views`, and at most what one dispatch
  // of (triangle, view) threads can index).
  static int batch_size(uint64_t triangles, uint64_t texels_per_view, bool resolve, int views, uint64_t budget);
  // The device memory a method's batches may hold at once (256 MiB: enough views a batch to fill a
  // GPU, little against its memory), unless a test set another.
  static uint64_t batch_budget();
  // For tests: the budget methods' batches get (0: the default), to make them render in batches.
  static void set_batch_budget_for_testing(uint64_t bytes);

  // For tests: the capacities of the next render (0: sized from the scene and the views).
  void set_capacities_for_testing(uint32_t triangles, uint32_t items);
  // For tests of the methods that own one: the capacities every batch rasterizer starts with from
  // now on (0, 0: sized from the scene and the views), to make their first batch retry.
  static void set_first_capacities_for_testing(uint32_t triangles, uint32_t items);

 private:
  Device* device_;
  Buffer state_, orientation_, outline_, view_flags_;
  RasterScratch scratch_;
  RasterStats stats_;
  int attempts_ = 0;
};

}  // namespace penumbra::gpu
