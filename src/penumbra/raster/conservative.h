// Conservative rasterization: every texel a convex polygon touches, not only those whose
// centre it covers. sintorn2008 §3.2 needs it because the view samples listed in a texel lie
// anywhere inside it, and §4.1 rasterizes each triangle's influence region (a convex polygon
// on the far plane) the same way.
//
// Where sintorn2008 extends the polygon by half a texel in a geometry shader (and may add up to
// one texel at sharp corners), this is exact: texel (x, y), the closed square
// [x, x+1] x [y, y+1], is reported iff it meets the polygon (bounding-box overlap plus, for
// each polygon edge, the square's corner farthest inside that edge lying inside: the
// separating-axis test for a convex polygon and a square), with the polygon grown by 1e-5
// texel against rounding. Zero-area polygons (segments, points) cover the texels they touch.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/raster/rasterizer.h"

namespace penumbra {

// Convex polygons in texel space (LightView conventions: x right, y down, texel (i, j) is
// [i, i+1) x [j, j+1)), either winding, stored flat: polygon i is
// vertices[offsets[i], offsets[i + 1]).
struct ConvexPolygons {
  std::vector<Vec2f> vertices;
  std::vector<uint32_t> offsets{0};

  void add(std::span<const Vec2f> polygon);
  void clear() {
    vertices.clear();
    offsets.assign(1, 0);
  }
  size_t size() const { return offsets.size() - 1; }
  std::span<const Vec2f> operator[](size_t i) const {
    return {vertices.data() + offsets[i], offsets[i + 1] - offsets[i]};
  }
};

// Called once per (covered texel, polygon). Calls come from several threads at once, but all
// calls for one texel come from the same thread, in polygon order: per-texel data (a view-
// sample list, sintorn2008 §3) can be updated without atomics or locks.
using CoverageCallback = std::function<void(int x, int y, uint32_t index)>;
// The same coverage as spans: texels [x0, x1) of row y, once per (row of a tile, polygon).
using SpanCallback = std::function<void(int y, int x0, int x1, uint32_t index)>;

class ConservativeRasterizer {
 public:
  // tile_size: a power of two in [8, 256].
  explicit ConservativeRasterizer(int tile_size = 64);
  ~ConservativeRasterizer();
  ConservativeRasterizer(const ConservativeRasterizer&) = delete;
  ConservativeRasterizer& operator=(const ConservativeRasterizer&) = delete;

  // Every texel of a width x height image each polygon touches; index = polygon index.
  void polygons(const ConvexPolygons& polygons, int width, int height, const CoverageCallback& covered);
  // The same texels, one call per row span inside a tile (fewer calls for wide polygons).
  void polygon_spans(const ConvexPolygons& polygons, int width, int height, const SpanCallback& covered);
  // Every texel each triangle's projection touches, after clipping to the near and far planes
  // (only the part in front of the near plane counts); index = triangle index.
  void triangles(RasterTriangleView triangles, const LightView& view,
                 const RasterFilter& filter, const CoverageCallback& covered);

  // The scratch memory kept after covering `polygons` polygons of `vertices` vertices in all
  // (a triangle clipped to the view: 3 to 5) over a width x height image, binned as the
  // Rasterizer's (scratch_bytes there).
  static uint64_t scratch_bytes(uint64_t polygons, uint64_t vertices, int width, int height, int tile_size = 64);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int tile_size_;
};

}  // namespace penumbra
