// Internal to the raster layer: the tile grid and the binning of set-up primitives into
// tiles. Every raster mode is a parallel loop over tiles; a tile owns its texels, so the work
// done for one texel always runs on one thread, in input order, without atomics.
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <span>
#include <vector>

#include "penumbra/core/parallel.h"

namespace penumbra::raster_internal {

// Square tiles of 2^shift texels (a shift, not a division, maps texels to tiles when binning).
struct TileGrid {
  int width = 0, height = 0, shift = 6, tile = 64, nx = 0, ny = 0;

  TileGrid() = default;
  TileGrid(int w, int h, int tile_shift)
      : width(w), height(h), shift(tile_shift), tile(1 << tile_shift), nx((w + tile - 1) >> shift),
        ny((h + tile - 1) >> shift) {}
  int count() const { return nx * ny; }
  int x0(int t) const { return (t % nx) << shift; }
  int y0(int t) const { return (t / nx) << shift; }
  int x1(int t) const { return std::min(width, x0(t) + tile); }
  int y1(int t) const { return std::min(height, y0(t) + tile); }
};

// Primitives set up in fixed-size chunks of the input (never per thread, so the result does
// not depend on the thread count) and binned per tile in input order. An Item has a texel
// bounding box [x0, x1) x [y0, y1) inside the grid. Bins hold copies of the items, not
// pointers: a tile then reads its primitives sequentially, where chasing pointers into input
// order (spatially incoherent in most meshes) cost a cache miss per primitive and per tile.
// All vectors keep their capacity from one run to the next, so repeated renders (one shadow
// map per light sample, agrawala2000 §4) do not allocate.
template <class Item>
class TileBinner {
 public:
  // setup(chunk, begin, end, items) appends the items made from inputs [begin, end) of
  // chunk `chunk`; it runs on several threads at once, one chunk each.
  template <class Setup>
  void run(size_t n, size_t chunk_size, const TileGrid& grid, Setup&& setup) {
    grid_ = grid;
    chunk_count_ = (n + chunk_size - 1) / chunk_size;
    if (chunks_.size() < chunk_count_) chunks_.resize(chunk_count_);
    const size_t tiles = static_cast<size_t>(grid.count());
    counts_.assign(chunk_count_ * tiles, 0);
    parallel_for(chunk_count_, 1, [&](size_t begin, size_t end) {
      for (size_t c = begin; c < end; ++c) {
        std::vector<Item>& items = chunks_[c];
        items.clear();
        setup(c, c * chunk_size, std::min(n, (c + 1) * chunk_size), items);
        uint32_t* counts = counts_.data() + c * tiles;
        for (const Item& it : items)
          for_each_tile(it, [&](size_t t) { ++counts[t]; });
      }
    });
    // Exclusive scan in tile-major, chunk-minor order: each tile's entries come out in
    // input order.
    offsets_.assign(tiles + 1, 0);
    size_t total = 0;
    for (size_t t = 0; t < tiles; ++t) {
      offsets_[t] = total;
      for (size_t c = 0; c < chunk_count_; ++c) {
        uint32_t k = counts_[c * tiles + t];
        counts_[c * tiles + t] = static_cast<uint32_t>(total - offsets_[t]);
        total += k;
      }
    }
    offsets_[tiles] = total;
    entries_.resize(total);
    parallel_for(chunk_count_, 1, [&](size_t begin, size_t end) {
      for (size_t c = begin; c < end; ++c) {
        uint32_t* cursor = counts_.data() + c * tiles;
        for (const Item& it : chunks_[c])
          for_each_tile(it, [&](size_t t) { entries_[offsets_[t] + cursor[t]++] = it; });
      }
    });
  }

  // What run() keeps for n inputs that set up `items` items binned as `entries` (item, tile)
  // pairs: each chunk's items (push_back growth: up to twice their size), the per-chunk tile
  // counts, the tile offsets and the binned copies.
  static uint64_t bytes(size_t n, size_t chunk_size, const TileGrid& grid, uint64_t items, uint64_t entries) {
    const uint64_t chunks = (n + chunk_size - 1) / chunk_size, tiles = static_cast<uint64_t>(grid.count());
    return chunks * sizeof(std::vector<Item>) + 2 * items * sizeof(Item) + chunks * tiles * sizeof(uint32_t) +
           (tiles + 1) * sizeof(size_t) + entries * sizeof(Item);
  }

  std::span<const Item> tile(int t) const {
    return {entries_.data() + offsets_[t], offsets_[t + 1] - offsets_[t]};
  }
  size_t item_count() const {
    size_t k = 0;
    for (size_t c = 0; c < chunk_count_; ++c) k += chunks_[c].size();
    return k;
  }
  size_t entry_count() const { return entries_.size(); }

 private:
  template <class F>
  void for_each_tile(const Item& it, F&& f) const {
    int tx0 = it.x0 >> grid_.shift, tx1 = (it.x1 - 1) >> grid_.shift;
    int ty0 = it.y0 >> grid_.shift, ty1 = (it.y1 - 1) >> grid_.shift;
    for (int ty = ty0; ty <= ty1; ++ty)
      for (int tx = tx0; tx <= tx1; ++tx) f(static_cast<size_t>(ty) * grid_.nx + tx);
  }

  TileGrid grid_;
  size_t chunk_count_ = 0;
  std::vector<std::vector<Item>> chunks_;
  std::vector<uint32_t> counts_;
  std::vector<size_t> offsets_;
  std::vector<Item> entries_;
};

// Runs body(tile) over every tile of the grid, load-balanced (tiles differ a lot in cost).
template <class Body>
void for_each_tile(const TileGrid& grid, Body&& body) {
  parallel_for(grid.count(), 1, [&](size_t begin, size_t end) {
    for (int t = static_cast<int>(begin); t < static_cast<int>(end); ++t) body(t);
  });
}

// log2 of a tile size: a power of two in [8, 256], else -1.
inline int tile_shift(int tile_size) {
  if (tile_size < 8 || tile_size > 256 || !std::has_single_bit(static_cast<unsigned>(tile_size))) return -1;
  return std::countr_zero(static_cast<unsigned>(tile_size));
}

}  // namespace penumbra::raster_internal
