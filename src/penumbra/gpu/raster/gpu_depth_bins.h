// Depth-bin masks on the device (raster/rasterizer.h DepthBinMasks): one bit per depth bin and
// texel, bit k of texel (x, y) set when some fragment through its centre lies in bin k. The
// slicing pass of eisemann2006 §3.4, rendered by GpuRasterizer::depth_bin_masks with the CPU's
// coverage and depths (raster/raster_shared.h) and the CPU's bins (raster_bins_shared.h).
#pragma once

#include <cstdint>

#include "penumbra/gpu/buffer.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/raster/rasterizer.h"

namespace penumbra::gpu {

class GpuDepthBinMasks {
 public:
  int width() const { return width_; }
  int height() const { return height_; }
  const LightView& view() const { return view_; }
  // uint per texel, row-major (DepthBinMasks::masks), and the view's RasterView record.
  uint64_t masks() const { return masks_.address(); }
  uint64_t view_record() const { return view_record_.address(); }
  // The masks copied back (tests and tools).
  DepthBinMasks download() const;
  // With DepthBins::nearest: a float per bin and texel (DepthBinMasks::nearest's layout), else 0.
  uint64_t nearest() const { return nearest_bins_ > 0 ? nearest_.address() : 0; }
  int nearest_bins() const { return nearest_bins_; }
  uint64_t device_bytes() const { return masks_.bytes() + nearest_.bytes() + view_record_.bytes(); }
  // What a w x h image of masks holds, its view record included (and `nearest_bins` bins'
  // nearest depths).
  static uint64_t bytes(int w, int h, int nearest_bins = 0);

 private:
  friend class GpuRasterizer;
  void resize(Device& device, int w, int h, int nearest_bins);
  int width_ = 0, height_ = 0, nearest_bins_ = 0;
  LightView view_;
  Buffer masks_, nearest_, view_record_;
};

}  // namespace penumbra::gpu
