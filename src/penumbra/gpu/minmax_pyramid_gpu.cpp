#include "penumbra/gpu/minmax_pyramid_gpu.h"

#include <vector>

#include "penumbra/gpu/minmax_pyramid_shared.h"
#include "penumbra/raster/depth_image_walk_shared.h"

namespace penumbra::gpu {

namespace {

// The level table of a width x height image's pyramid (MinMaxPyramid's levels).
std::vector<shader::DepthPyramidLevel> level_table(int width, int height) {
  std::vector<shader::DepthPyramidLevel> levels;
  uint32_t offset = 0;
  for (int w = width, h = height;; w = (w + 1) / 2, h = (h + 1) / 2) {
    levels.push_back({offset, w, h, 0});
    offset += static_cast<uint32_t>(w) * static_cast<uint32_t>(h);
    if (w == 1 && h == 1) break;
  }
  return levels;
}

}  // namespace

uint64_t GpuMinMaxPyramid::bytes(int width, int height) {
  return MinMaxPyramid::bytes(width, height) + level_table(width, height).size() * sizeof(shader::DepthPyramidLevel);
}

void GpuMinMaxPyramid::resize(Device& device, int width, int height, const std::string& what) {
  if (width == width_ && height == height_ && !nodes_.empty()) return;
  nodes_ = Buffer();
  nodes_ = Buffer(device, MinMaxPyramid::bytes(width, height), what);
  const std::vector<shader::DepthPyramidLevel> levels = level_table(width, height);
  levels_ = make_buffer<shader::DepthPyramidLevel>(device, levels, what + "'s levels");
  level_count_ = static_cast<int>(levels.size());
  width_ = width;
  height_ = height;
}

void GpuMinMaxPyramid::build(CommandList& commands) const {
  int w = width_, h = height_;
  uint32_t offset = 0;
  while (w > 1 || h > 1) {
    shader::MinMaxPyramidReduceParams p{};
    p.nodes = nodes_.address();
    p.child_offset = offset;
    p.parent_offset = offset + static_cast<uint32_t>(w) * static_cast<uint32_t>(h);
    p.child_width = w;
    p.child_height = h;
    p.parent_width = (w + 1) / 2;
    p.parent_height = (h + 1) / 2;
    commands.dispatch("minmax_pyramid_reduce", static_cast<uint64_t>(p.parent_width) * p.parent_height, p);
    offset = p.parent_offset;
    w = p.parent_width;
    h = p.parent_height;
  }
}

std::vector<DepthRange> GpuMinMaxPyramid::download_nodes() const {
  return nodes_.download_vector<DepthRange>(MinMaxPyramid::nodes(width_, height_));
}

}  // namespace penumbra::gpu
