// Min/max pyramids on the device (raster/minmax_pyramid.h's quadtrees; layout in
// gpu/minmax_pyramid_shared.h): a method's kernel writes level 0 (each texel's depth range) into
// level0(), build() records one reduction per level above it (minmax_pyramid_reduce.comp), and
// the walk kernels read it with depth_pyramid_ref (raster/depth_image_walk_shared.h). Shared by
// every method that walks depth images on the GPU (mlsm, mtsm, coherent-rt).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/commands.h"
#include "penumbra/raster/minmax_pyramid.h"

namespace penumbra::gpu {

class GpuMinMaxPyramid {
 public:
  // Room for the pyramid of a width x height image (reallocated only when the size changes).
  void resize(Device& device, int width, int height, const std::string& what);
  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return width_ == 0; }
  // The whole pyramid's nodes (level 0 first) and level 0's: vec2 (lo, hi) per node.
  uint64_t address() const { return nodes_.address(); }
  // Its level table (raster/depth_image_walk_shared.h DepthPyramidLevel per level) and levels:
  // what a kernel's depth_pyramid_ref takes.
  uint64_t levels_address() const { return levels_.address(); }
  int levels() const { return level_count_; }
  Buffer& buffer() { return nodes_; }
  // Records the reductions of every level above level 0 (what level 0 holds must be written
  // before, in the same command list or earlier).
  void build(CommandList& commands) const;
  // Every level's nodes read back, level 0 first (tests).
  std::vector<DepthRange> download_nodes() const;
  uint64_t device_bytes() const { return nodes_.bytes() + levels_.bytes(); }
  static uint64_t bytes(int width, int height);

 private:
  int width_ = 0, height_ = 0, level_count_ = 0;
  Buffer nodes_, levels_;
};

}  // namespace penumbra::gpu
