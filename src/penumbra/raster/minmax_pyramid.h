// Min/max depth pyramids (quadtrees) over a depth map or a layered depth map, for
// hierarchical tracing of shadow rays through depth images: agrawala2000 §5.1 (procedure
// Trace over min/max quadtrees) and xie2007 §4.3 (each node holds min_z and max_z of its
// four children, over all layers).
//
// Level 0 is the image itself; level l + 1 has ceil(w_l / 2) x ceil(h_l / 2) nodes, node
// (x, y) bounding nodes (2x .. 2x+1, 2y .. 2y+1) of level l that exist (at an odd edge a node
// has one or two children). The last level is 1 x 1. So node (x, y) of level l covers the
// texels [x 2^l, min(width, (x+1) 2^l)) x [y 2^l, min(height, (y+1) 2^l)) of level 0, for any
// image size. Empty texels (no surface) are empty ranges (lo = +inf, hi = -inf): they never
// overlap a ray's depth interval, and a node is empty iff all its texels are.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/raster/depth_map.h"

namespace penumbra {

// Which depth a pyramid is built over.
enum class DepthKind {
  Linear,  // linear depth z (world units): for thresholds in light-view space
  Window,  // window depth in [0, 1]: affine along a screen-space segment (xie2007 §6.1)
};

struct DepthRange {
  float lo = kInfinity, hi = -kInfinity;
  bool empty() const { return lo > hi; }
  // Whether [a, b] (a <= b) meets the range; never for an empty range.
  bool overlaps(float a, float b) const { return lo <= hi && lo <= b && a <= hi; }
  void extend(const DepthRange& o) {
    lo = std::min(lo, o.lo);
    hi = std::max(hi, o.hi);
  }
};

class MinMaxPyramid {
 public:
  MinMaxPyramid() = default;
  // From per-texel ranges of a width x height image (row-major).
  MinMaxPyramid(int width, int height, std::span<const DepthRange> texels);
  // Over the nearest surface of each texel.
  MinMaxPyramid(const DepthMap& map, DepthKind kind = DepthKind::Linear);
  // Over all layers of each texel: [first layer, last layer].
  MinMaxPyramid(const LayeredDepthMap& map, DepthKind kind = DepthKind::Linear);

  // Nodes of the pyramid of a width x height image (every level), and what they hold: for
  // memory estimates, and for per-node data beside a pyramid.
  static uint64_t nodes(int width, int height);
  static uint64_t bytes(int width, int height) { return nodes(width, height) * sizeof(DepthRange); }

  int levels() const { return static_cast<int>(levels_.size()); }
  int width(int level = 0) const { return levels_[level].width; }
  int height(int level = 0) const { return levels_[level].height; }
  DepthRange range(int level, int x, int y) const {
    const Level& l = levels_[level];
    return l.nodes[static_cast<size_t>(y) * l.width + x];
  }
  // A whole level, row-major (width(level) per row), for traversals that index it directly.
  std::span<const DepthRange> level(int level) const { return levels_[level].nodes; }
  float min(int level, int x, int y) const { return range(level, x, y).lo; }
  float max(int level, int x, int y) const { return range(level, x, y).hi; }
  // The whole image's range (the root).
  DepthRange root() const { return levels_.back().nodes[0]; }
  // Texels of level 0 a node covers: [*x0, *x1) x [*y0, *y1).
  void texels(int level, int x, int y, int* x0, int* y0, int* x1, int* y1) const;

 private:
  struct Level {
    int width = 0, height = 0;
    std::vector<DepthRange> nodes;
  };
  void build_levels();

  std::vector<Level> levels_;
};

}  // namespace penumbra
