#include "penumbra/gpu/raster/raster_scratch.h"

#include <algorithm>

#include "penumbra/core/error.h"

namespace penumbra::gpu {
namespace {

constexpr uint64_t kMaxCapacity = 0xffffffffu;  // items and triangles are indexed by uint32

// Room for `needed` with a margin, so a scene that grows a little does not retry every frame.
uint64_t grown(uint64_t needed) { return needed + needed / 4 + 64; }

}  // namespace

void RasterScratch::ensure(Device& device, uint64_t triangles, uint64_t items) {
  if (triangles > kMaxCapacity || items > kMaxCapacity)
    throw Error("GPU rasterizer: {} needs {} set-up triangles and {} work items, more than it can index (at most {})",
                owner_, triangles, items, kMaxCapacity);
  if (triangles > triangle_capacity_) {
    triangles_ = Buffer();  // free first: the old buffer's contents are not needed
    triangles_ = Buffer(device, triangles * triangle_bytes_, owner_ + "'s set-up triangles");
    triangle_capacity_ = static_cast<uint32_t>(triangles);
  }
  if (items > item_capacity_) {
    items_ = Buffer();
    items_ = Buffer(device, items * sizeof(shader::GpuRasterItem), owner_ + "'s work items");
    item_capacity_ = static_cast<uint32_t>(items);
  }
}

bool RasterScratch::fitted_or_grown(Device& device, const shader::GpuRasterState& s, RasterStats* stats) {
  if (s.setup_count <= triangle_capacity_ && s.item_count <= item_capacity_) {
    stats->setup = s.setup_count;
    stats->bin_entries = s.item_count;
    stats->fragments = s.fragments;
    return true;
  }
  // Every count is what the written triangles asked for, so grow to at least that (the items of
  // triangles that found no room are counted on the next try).
  ensure(device, std::max<uint64_t>(triangle_capacity_, s.setup_count > triangle_capacity_ ? grown(s.setup_count) : 0),
         std::max<uint64_t>(item_capacity_, s.item_count > item_capacity_ ? grown(s.item_count) : 0));
  return false;
}

void RasterScratch::set_for_testing(Device& device, uint32_t triangles, uint32_t items) {
  triangles_ = Buffer(device, std::max<uint64_t>(1, triangles) * triangle_bytes_, owner_ + "'s set-up triangles");
  items_ = Buffer(device, std::max<uint64_t>(1, items) * sizeof(shader::GpuRasterItem), owner_ + "'s work items");
  triangle_capacity_ = triangles;
  item_capacity_ = items;
}

}  // namespace penumbra::gpu
