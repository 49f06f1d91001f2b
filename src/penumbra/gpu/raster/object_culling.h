// Caster culling per view on the GPU (issue 34 part 3; the CPU's is raster/caster_culling.h):
// the scene's objects whose bounds lie wholly outside a view's frustum are flagged
// kRasterObjectSkip (gpu/raster/raster_layout_shared.h) for the rasterizer's per-object flags, so
// its set-up skips their triangles. Whole objects (the GPU scene's unit), so a kept object is
// rasterized whole and the map is the one every object gives.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/device.h"
#include "penumbra/gpu/raster/gpu_batch_rasterizer.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/scene/scene.h"

namespace penumbra::gpu {

class ObjectCulling {
 public:
  // The objects' bounds; call again when the geometry changes.
  void prepare(Device& device, const Scene& scene);
  // The flags for `view` uploaded, and their device address; 0 (no flags) when no object is
  // culled. Call only when no recorded kernel still reads the previous flags (after a flush).
  // *culled = the triangles of the objects left out.
  uint64_t flags_for(const LightView& view, uint64_t* culled);
  // The same for a batch of views, as the batch rasterizer takes them (*out: a row of flags per
  // view); false, and *out left empty, when no view leaves any object out. *culled = the
  // triangles left out, summed over the views.
  bool flags_for_views(std::span<const LightView> views, RasterViewCulling* out, uint64_t* culled) const;

 private:
  // kRasterObjectSkip or 0 per object for `view` into flags[0, objects); the triangles left out.
  uint64_t flags_into(const LightView& view, uint32_t* flags) const;

  std::vector<Bounds3f> bounds_;
  std::vector<uint64_t> triangles_;
  std::vector<uint32_t> flags_;
  Buffer buffer_;
};

}  // namespace penumbra::gpu
