#include "penumbra/raster/minmax_pyramid.h"

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra {

MinMaxPyramid::MinMaxPyramid(int width, int height, std::span<const DepthRange> texels) {
  if (width < 1 || height < 1 || texels.size() != static_cast<size_t>(width) * height)
    throw Error("MinMaxPyramid: {} texel ranges for a {}x{} image", texels.size(), width, height);
  Level base;
  base.width = width;
  base.height = height;
  base.nodes.assign(texels.begin(), texels.end());
  levels_.push_back(std::move(base));
  build_levels();
}

MinMaxPyramid::MinMaxPyramid(const DepthMap& map, DepthKind kind) {
  if (map.width < 1 || map.height < 1) throw Error("MinMaxPyramid: empty depth map");
  Level base;
  base.width = map.width;
  base.height = map.height;
  base.nodes.resize(static_cast<size_t>(map.width) * map.height);
  const std::vector<float>& d = kind == DepthKind::Linear ? map.z : map.depth;
  parallel_for(base.nodes.size(), 16384, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i)
      base.nodes[i] = map.triangle[i] != kNoTriangle ? DepthRange{d[i], d[i]} : DepthRange{};
  });
  levels_.push_back(std::move(base));
  build_levels();
}

MinMaxPyramid::MinMaxPyramid(const LayeredDepthMap& map, DepthKind kind) {
  if (map.width < 1 || map.height < 1) throw Error("MinMaxPyramid: empty layered depth map");
  Level base;
  base.width = map.width;
  base.height = map.height;
  base.nodes.resize(static_cast<size_t>(map.width) * map.height);
  parallel_for(base.nodes.size(), 16384, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      int n = map.counts[i];
      if (n == 0) {
        base.nodes[i] = {};
        continue;
      }
      const DepthSample* s = map.samples.data() + i * map.max_layers;
      // Layers are sorted nearest first.
      base.nodes[i] = kind == DepthKind::Linear ? DepthRange{s[0].z, s[n - 1].z}
                                                : DepthRange{s[0].depth, s[n - 1].depth};
    }
  });
  levels_.push_back(std::move(base));
  build_levels();
}

void MinMaxPyramid::build_levels() {
  while (levels_.back().width > 1 || levels_.back().height > 1) {
    const Level& child = levels_.back();
    Level parent;
    parent.width = (child.width + 1) / 2;
    parent.height = (child.height + 1) / 2;
    parent.nodes.resize(static_cast<size_t>(parent.width) * parent.height);
    parallel_for(parent.height, 16, [&](size_t begin, size_t end) {
      for (int y = static_cast<int>(begin); y < static_cast<int>(end); ++y) {
        int cy0 = 2 * y, cy1 = std::min(child.height, 2 * y + 2);
        for (int x = 0; x < parent.width; ++x) {
          int cx0 = 2 * x, cx1 = std::min(child.width, 2 * x + 2);
          DepthRange r2;
          for (int cy = cy0; cy < cy1; ++cy)
            for (int cx = cx0; cx < cx1; ++cx) r2.extend(child.nodes[static_cast<size_t>(cy) * child.width + cx]);
          parent.nodes[static_cast<size_t>(y) * parent.width + x] = r2;
        }
      }
    });
    levels_.push_back(std::move(parent));
  }
}

uint64_t MinMaxPyramid::nodes(int width, int height) {
  // The levels of build_levels(): ceil halves down to 1 x 1.
  uint64_t nodes = static_cast<uint64_t>(width) * static_cast<uint64_t>(height);
  while (width > 1 || height > 1) {
    width = (width + 1) / 2;
    height = (height + 1) / 2;
    nodes += static_cast<uint64_t>(width) * static_cast<uint64_t>(height);
  }
  return nodes;
}

void MinMaxPyramid::texels(int level, int x, int y, int* x0, int* y0, int* x1, int* y1) const {
  *x0 = x << level;
  *y0 = y << level;
  *x1 = std::min(levels_[0].width, (x + 1) << level);
  *y1 = std::min(levels_[0].height, (y + 1) << level);
}

}  // namespace penumbra
