// The GPU rasterizer's layered depth maps and fragment lists (docs/raster.md, "The GPU
// rasterizer"; layouts in gpu/raster/raster_modes_shared.h), rendered by
// GpuRasterizer::layered_depth_map and GpuRasterizer::fragment_lists: the CPU rasterizer's
// LayeredDepthMap (xie2007 §4.2) and FragmentLists (xie2007 §5) on the device, with the same
// fragments (the same set-up and scan as the depth map) and the same rules.
#pragma once

#include <cstdint>

#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/scan_gpu.h"
#include "penumbra/raster/depth_map.h"
#include "penumbra/raster/fragment_lists.h"
#include "penumbra/raster/light_view.h"

namespace penumbra::gpu {

class GpuRasterizer;

// The k nearest distinct surfaces per texel on the device.
class GpuLayeredDepthMap {
 public:
  int width() const { return width_; }
  int height() const { return height_; }
  int layers() const { return k_; }
  bool empty() const { return width_ == 0; }
  const LightView& view() const { return view_; }
  // The smallest linear depth in the map (+inf when it is empty): xie2007's z_min.
  float z_min() const { return z_min_; }
  // Device addresses: counts (uint per texel), samples (k per texel, 16 bytes each) and the view's
  // RasterView record.
  uint64_t counts() const { return counts_.address(); }
  uint64_t samples() const { return samples_.address(); }
  uint64_t view_record() const { return view_record_.address(); }

  // Read back into the CPU's form (tests and tools).
  LayeredDepthMap download() const;
  uint64_t device_bytes() const;
  // What a w x h map of k layers holds.
  static uint64_t bytes(int w, int h, int k);

 private:
  friend class GpuRasterizer;
  void resize(Device& device, int w, int h, int k);
  int width_ = 0, height_ = 0, k_ = 0;
  LightView view_;
  float z_min_ = kInfinity;
  Buffer keys_, front_, counts_, samples_, view_record_;
};

// Every fragment through each texel centre, sorted by depth, on the device.
class GpuFragmentLists {
 public:
  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return width_ == 0; }
  const LightView& view() const { return view_; }
  // The fragments in the lists (the scan's total).
  uint64_t total() const { return total_; }
  // Device addresses: offsets (texels + 1 uints), fragments (12 bytes each), the view's record.
  uint64_t offsets() const { return offsets_.address(); }
  uint64_t fragments() const { return fragments_.address(); }
  uint64_t view_record() const { return view_record_.address(); }
  uint32_t capacity() const { return capacity_; }

  FragmentLists download() const;
  uint64_t device_bytes() const;
  // What a w x h map holds besides its fragments, and per fragment.
  static uint64_t bytes(int w, int h, uint64_t fragments);

 private:
  friend class GpuRasterizer;
  void resize(Device& device, int w, int h);
  void reserve(Device& device, uint64_t fragments);
  int width_ = 0, height_ = 0;
  LightView view_;
  uint64_t total_ = 0;
  uint32_t capacity_ = 0;
  Buffer counts_, offsets_, fragments_, view_record_;
  GpuScan scan_;
};

}  // namespace penumbra::gpu
