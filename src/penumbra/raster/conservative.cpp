#include "penumbra/raster/conservative.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/raster/clipping.h"
#include "penumbra/raster/tiling.h"

namespace penumbra {
namespace {

using raster_internal::TileBinner;
using raster_internal::TileGrid;

constexpr size_t kChunkSize = 1024;
// Polygons grow by this many texels against rounding: conservative, and far below the one-
// texel slack sintorn2008 §3.2 accepts.
constexpr double kTolerance = 1e-5;

struct Point2 {
  double x, y;
};

// A polygon ready to cover: its texel bounding box (every texel whose closed square meets the
// polygon's bounding box, clipped to the image) and where its vertices are.
struct CoverItem {
  int32_t x0, y0, x1, y1;
  uint32_t index;
  uint32_t chunk, first, count;
};

// Appends the item for polygon `index` with vertices pts[first, first + count) of `chunk`;
// false when it misses the image.
bool set_up(const std::vector<Point2>& pts, uint32_t first, uint32_t count, uint32_t index,
            uint32_t chunk, int width, int height, CoverItem* item) {
  if (count == 0) return false;
  double x0 = kInfinity, x1 = -kInfinity, y0 = kInfinity, y1 = -kInfinity;
  for (uint32_t k = first; k < first + count; ++k) {
    if (!std::isfinite(pts[k].x) || !std::isfinite(pts[k].y)) return false;
    x0 = std::min(x0, pts[k].x); x1 = std::max(x1, pts[k].x);
    y0 = std::min(y0, pts[k].y); y1 = std::max(y1, pts[k].y);
  }
  // Square [i, i+1] meets [x0, x1] iff i <= x1 and i + 1 >= x0.
  double ix0 = std::ceil(x0 - kTolerance - 1), ix1 = std::floor(x1 + kTolerance);
  double iy0 = std::ceil(y0 - kTolerance - 1), iy1 = std::floor(y1 + kTolerance);
  item->x0 = static_cast<int32_t>(std::clamp(ix0, 0.0, double(width)));
  item->x1 = static_cast<int32_t>(std::clamp(ix1 + 1, 0.0, double(width)));
  item->y0 = static_cast<int32_t>(std::clamp(iy0, 0.0, double(height)));
  item->y1 = static_cast<int32_t>(std::clamp(iy1 + 1, 0.0, double(height)));
  if (item->x0 >= item->x1 || item->y0 >= item->y1) return false;
  item->index = index;
  item->chunk = chunk;
  item->first = first;
  item->count = count;
  return true;
}

// Reports the texels of [rx0, rx1) x [ry0, ry1) whose square meets the polygon, as one span
// [x0, x1) per row y: fn(y, x0, x1).
template <class Fn>
void cover(const CoverItem& it, const Point2* p, int rx0, int ry0, int rx1, int ry1, Fn&& fn) {
  const int x0 = std::max(rx0, it.x0), x1 = std::min(rx1, it.x1);
  const int y0 = std::max(ry0, it.y0), y1 = std::min(ry1, it.y1);
  if (x0 >= x1 || y0 >= y1) return;
  const uint32_t n = it.count;
  double area = 0;
  for (uint32_t k = 0; k < n; ++k) {
    const Point2& a = p[k];
    const Point2& b = p[(k + 1) % n];
    area += a.x * b.y - a.y * b.x;
  }
  const double sign = area < 0 ? -1.0 : 1.0;
  // Each edge, E(P) = sign * cross(b - a, P - a) >= 0 inside, bounds the columns i whose
  // square's best corner (i + [nx > 0], y + [ny > 0]) is inside. Its terms that do not depend
  // on the row are set up once per polygon and tile (the rows sum them in the same order).
  struct Edge {
    double nx, ny, c, right, slack;
    int below;  // [ny > 0]
  };
  constexpr uint32_t kEdgesOnStack = 32;
  Edge on_stack[kEdgesOnStack];
  std::vector<Edge> on_heap;
  if (n > kEdgesOnStack) on_heap.resize(n);
  Edge* edges = n > kEdgesOnStack ? on_heap.data() : on_stack;
  for (uint32_t k = 0; k < n; ++k) {
    const Point2& a = p[k];
    const Point2& b = p[k + 1 == n ? 0 : k + 1];
    Edge& e = edges[k];
    e.nx = -sign * (b.y - a.y);
    e.ny = sign * (b.x - a.x);
    e.c = -(e.nx * a.x + e.ny * a.y);
    e.right = e.nx > 0 ? e.nx : 0;
    e.slack = kTolerance * (std::abs(e.nx) + std::abs(e.ny));
    e.below = e.ny > 0 ? 1 : 0;
  }
  for (int y = y0; y < y1; ++y) {
    double lo = x0, hi = x1 - 1;
    for (uint32_t k = 0; k < n && lo <= hi; ++k) {
      const Edge& e = edges[k];
      double K = e.ny * (y + e.below) + e.c + e.right + e.slack;
      if (e.nx > 0)
        lo = std::max(lo, std::ceil(-K / e.nx));
      else if (e.nx < 0)
        hi = std::min(hi, std::floor(K / -e.nx));
      else if (K < 0)
        hi = lo - 1;
    }
    if (lo <= hi) fn(y, static_cast<int>(lo), static_cast<int>(hi) + 1);
  }
}

}  // namespace

void ConvexPolygons::add(std::span<const Vec2f> polygon) {
  vertices.insert(vertices.end(), polygon.begin(), polygon.end());
  offsets.push_back(static_cast<uint32_t>(vertices.size()));
}

struct ConservativeRasterizer::Impl {
  TileBinner<CoverItem> binner;
  std::vector<std::vector<Point2>> chunk_points;

  void prepare_chunks(size_t n) {
    size_t chunks = (n + kChunkSize - 1) / kChunkSize;
    if (chunk_points.size() < chunks) chunk_points.resize(chunks);
  }
  void cover_tiles(const TileGrid& grid, const CoverageCallback& covered) {
    cover_tile_spans(grid, [&](int y, int x0, int x1, uint32_t index) {
      for (int x = x0; x < x1; ++x) covered(x, y, index);
    });
  }
  template <class Fn>
  void cover_tile_spans(const TileGrid& grid, Fn&& span) {
    raster_internal::for_each_tile(grid, [&](int tile) {
      const int x0 = grid.x0(tile), y0 = grid.y0(tile), x1 = grid.x1(tile), y1 = grid.y1(tile);
      for (const CoverItem& it : binner.tile(tile)) {
        const Point2* p = chunk_points[it.chunk].data() + it.first;
        const uint32_t index = it.index;
        cover(it, p, x0, y0, x1, y1, [&](int y, int sx0, int sx1) { span(y, sx0, sx1, index); });
      }
    });
  }
  void bin_polygons(const ConvexPolygons& polys, const TileGrid& grid, int width, int height);
};

uint64_t ConservativeRasterizer::scratch_bytes(uint64_t polygons, uint64_t vertices, int width, int height,
                                               int tile_size) {
  const TileGrid grid(width, height, std::max(0, raster_internal::tile_shift(tile_size)));
  const uint64_t entries = 2 * polygons + 2 * static_cast<uint64_t>(grid.count());
  const uint64_t chunks = (polygons + kChunkSize - 1) / kChunkSize;
  // The vertices per chunk (push_back growth: up to twice their size) and the binner's part.
  return chunks * sizeof(std::vector<Point2>) + 2 * vertices * sizeof(Point2) +
         TileBinner<CoverItem>::bytes(polygons, kChunkSize, grid, polygons, entries);
}

ConservativeRasterizer::ConservativeRasterizer(int tile_size)
    : impl_(std::make_unique<Impl>()), tile_size_(tile_size) {
  if (raster_internal::tile_shift(tile_size) < 0)
    throw Error("ConservativeRasterizer: tile size {} must be a power of two in [8, 256]", tile_size);
}

ConservativeRasterizer::~ConservativeRasterizer() = default;

void ConservativeRasterizer::polygons(const ConvexPolygons& polys, int width, int height,
                                      const CoverageCallback& covered) {
  if (width < 1 || height < 1) throw Error("ConservativeRasterizer: empty image {}x{}", width, height);
  TileGrid grid(width, height, raster_internal::tile_shift(tile_size_));
  impl_->bin_polygons(polys, grid, width, height);
  impl_->cover_tiles(grid, covered);
}

void ConservativeRasterizer::polygon_spans(const ConvexPolygons& polys, int width, int height,
                                           const SpanCallback& covered) {
  if (width < 1 || height < 1) throw Error("ConservativeRasterizer: empty image {}x{}", width, height);
  TileGrid grid(width, height, raster_internal::tile_shift(tile_size_));
  impl_->bin_polygons(polys, grid, width, height);
  impl_->cover_tile_spans(grid, covered);
}

void ConservativeRasterizer::Impl::bin_polygons(const ConvexPolygons& polys, const TileGrid& grid, int width,
                                                int height) {
  prepare_chunks(polys.size());
  binner.run(polys.size(), kChunkSize, grid, [&](size_t chunk, size_t begin, size_t end, std::vector<CoverItem>& out) {
    std::vector<Point2>& pts = chunk_points[chunk];
    pts.clear();
    for (size_t i = begin; i < end; ++i) {
      uint32_t first = static_cast<uint32_t>(pts.size());
      for (Vec2f v : polys[i]) pts.push_back({v.x, v.y});
      CoverItem item;
      if (set_up(pts, first, static_cast<uint32_t>(pts.size()) - first, static_cast<uint32_t>(i),
                 static_cast<uint32_t>(chunk), width, height, &item))
        out.push_back(item);
      else
        pts.resize(first);
    }
  });
}

void ConservativeRasterizer::triangles(RasterTriangleView tris, const LightView& view,
                                       const RasterFilter& filter, const CoverageCallback& covered) {
  TileGrid grid(view.width(), view.height(), raster_internal::tile_shift(tile_size_));
  impl_->prepare_chunks(tris.size());
  const raster_internal::TriangleClipper clipper(view);
  impl_->binner.run(tris.size(), kChunkSize, grid, [&](size_t chunk, size_t begin, size_t end, std::vector<CoverItem>& out) {
    std::vector<Point2>& pts = impl_->chunk_points[chunk];
    pts.clear();
    raster_internal::ClipVertex poly[raster_internal::kMaxClipVertices];
    for (size_t i = begin; i < end; ++i) {
      const RasterTriangle& tri = tris[i];
      if (!(tri.opacity > 0) || (filter.opaque_only && tris.semi_transparent(tri))) continue;
      if (filter.culling != FaceCulling::None) {
        bool front = raster_internal::faces_light(tri, view);
        if (front != (filter.culling == FaceCulling::Back)) continue;
      }
      int n = clipper.clip(tri, poly);
      if (n == 0) continue;
      uint32_t first = static_cast<uint32_t>(pts.size());
      for (int k = 0; k < n; ++k)
        pts.push_back({double{poly[k].x} / poly[k].w, double{poly[k].y} / poly[k].w});
      CoverItem item;
      if (set_up(pts, first, static_cast<uint32_t>(n), static_cast<uint32_t>(i),
                 static_cast<uint32_t>(chunk), view.width(), view.height(), &item))
        out.push_back(item);
      else
        pts.resize(first);
    }
  });
  impl_->cover_tiles(grid, covered);
}

}  // namespace penumbra
