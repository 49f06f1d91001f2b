// The scratch both GPU rasterizer modes (GpuRasterizer, GpuBatchRasterizer) grow and retry with:
// the set-up triangles and the work items, whose counts are only known once the set-up kernel
// has run. A render writes what fits and counts everything; the host reads the counts back and,
// where a buffer overflowed, grows it and renders again: work is never dropped (docs/raster.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>

#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/device.h"
#include "penumbra/gpu/raster/raster_layout_shared.h"
#include "penumbra/raster/rasterizer.h"

namespace penumbra::gpu {

// The set-up kernels' `culling` parameter for a filter: 0 none, 1 back faces, 2 front faces.
inline uint32_t raster_culling_code(const RasterFilter& filter) {
  return filter.culling == FaceCulling::None ? 0u : filter.culling == FaceCulling::Back ? 1u : 2u;
}

class RasterScratch {
 public:
  // `triangle_bytes`: one set-up triangle record's size; `owner`: what the buffers and the error
  // name ("the rasterizer", "the batch").
  RasterScratch(size_t triangle_bytes, std::string owner) : triangle_bytes_(triangle_bytes), owner_(std::move(owner)) {}

  uint64_t triangles_address() const { return triangles_.address(); }
  uint64_t items_address() const { return items_.address(); }
  uint32_t triangle_capacity() const { return triangle_capacity_; }
  uint32_t item_capacity() const { return item_capacity_; }
  bool empty() const { return triangle_capacity_ == 0 || item_capacity_ == 0; }
  uint64_t device_bytes() const { return triangles_.bytes() + items_.bytes(); }

  // Room for at least `triangles` and `items` (the old contents are dropped); a one-line error
  // past what a uint32 indexes.
  void ensure(Device& device, uint64_t triangles, uint64_t items);
  // After a render whose counters are `s`: true where both counts fitted (and they go into
  // `stats`: set-up triangles, work items, fragments); otherwise grows the buffers that
  // overflowed to their counts with a margin, and the render must run again.
  bool fitted_or_grown(Device& device, const shader::GpuRasterState& s, RasterStats* stats);
  // For tests: exactly these capacities (at least one record each), to make a render retry.
  void set_for_testing(Device& device, uint32_t triangles, uint32_t items);

 private:
  size_t triangle_bytes_;
  std::string owner_;
  Buffer triangles_, items_;
  uint32_t triangle_capacity_ = 0, item_capacity_ = 0;
};

}  // namespace penumbra::gpu
