// penumbra's CPU rasterizer: renders world-space triangles into images seen from a
// LightView, exactly and in parallel. One implementation serves every light-space method:
// shadow maps and PCF/PCSS (one depth map), agrawala2000 §4 (one depth map per light
// sample), agrawala2000 §5 and xie2007 §4 (depth maps and k-layer maps plus min/max
// pyramids), xie2007 §5 (fragment lists with opacity), sintorn2008 §3-4 (conservative
// coverage, conservative.h).
//
// How it works (docs/raster.md): triangles are transformed to homogeneous texel space,
// clipped against the near and far planes (and a guard band far outside the image, so the
// fixed-point edge functions cannot overflow), snapped to 1/256 texel and binned into square
// tiles; tiles are rasterized in parallel (oneTBB), each by one thread, visiting its
// triangles in input order. Coverage is sampled at texel centres with exact integer edge
// functions and the top-left fill rule (D3D/OpenGL convention in a y-down image), so two
// triangles sharing an edge cover each centre on it exactly once. Depth is interpolated from
// the unsnapped vertices: 1/z is affine in texel space for a perspective view, z for an
// orthographic one, and z = the linear depth of the LightView.
//
// Alpha textures (issue 20): a textured triangle (its alpha texture in the side table the
// RasterTriangleView carries, raster_triangle.h) is looked up
// per fragment where the view's ray through the texel centre meets it; a mask's holes drop the
// fragment, a blend texture scales its opacity. Every mode sees the same fragments.
//
// Every result is independent of the thread count. No mode allocates per fragment; a
// Rasterizer keeps its scratch memory between calls, so keep one per thread of control and
// reuse it (it is not itself safe to call from several threads at once).
#pragma once

#include <cstdint>
#include <cstdlib>
#include <new>
#include <functional>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "penumbra/raster/depth_map.h"
#include "penumbra/raster/fragment_lists.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/raster/raster_bins_shared.h"
#include "penumbra/raster/raster_triangle.h"

namespace penumbra {

// Facing is relative to the light: a triangle is front-facing when the light sees the side
// its normal cross(p1 - p0, p2 - p0) points to (counter-clockwise winding seen from the light).
enum class FaceCulling {
  None,
  Back,   // keep only triangles facing the light
  Front,  // keep only triangles facing away (sintorn2008 §3.3: back faces of closed casters)
};

// Which triangles a mode sees. Triangles with opacity <= 0 are always skipped: they cast
// nothing.
struct RasterFilter {
  FaceCulling culling = FaceCulling::None;
  // Skip semi-transparent triangles (opacity < 1): a map of the opaque casters only.
  bool opaque_only = false;
};

struct LayerOptions {
  int layers = 5;  // k; xie2007 §4.2 finds 5 enough for production scenes (1..255)
  // Two fragments of a texel are the same surface (one layer) when their linear depths differ
  // by at most this many world units. A watertight mesh gives exactly one fragment per
  // crossing, so this only merges coincident geometry (duplicated faces, a two-sided leaf
  // modelled as two triangles, decals). 0 merges only equal depths. See rasterizer.cpp for
  // the exact rule.
  float distinct_epsilon = 0;
  RasterFilter filter;
};

// Uniform bins of linear depth for Rasterizer::depth_bin_masks: bin k holds the depths in
// [first + k * width, first + (k + 1) * width). Depths before the first bin fall into it and
// depths after the last into the last (the caller clips with the view's near and far planes;
// this only absorbs float rounding at the ends).
//
// Bins per tile of texels: when `tiles` is not empty, the texels of tile (tx, ty) (square tiles of
// tile_side texels, a power of two, row-major from the image's top-left corner, the last row and
// column cut by the image's edge) bin by tiles[ty * ceil(width / tile_side) + tx] = (first,
// width) instead, with the same count: slices that follow the depth range of what each part of
// the image holds (occlusion-textures' `tiles`).
struct DepthBins {
  float first = 0;
  float width = 1;
  int count = 1;  // 1..32
  std::span<const Vec2f> tiles;
  int tile_side = 0;
  bool nearest = false;  // also keep each bin's nearest depth per texel (DepthBinMasks::nearest)
};

// DepthBins::tiles as the bins' records (raster_bins_shared.h), checked for a width x height
// image (who: the caller, for the error): tile (tx, ty) is records[ty * columns + tx], tiles of
// 2^shift texels. Empty records when bins.tiles is.
struct TileDepthBins {
  std::vector<shader::RasterDepthBins> records;
  int shift = 0;
  int columns = 0;
};
TileDepthBins tile_depth_bins(const DepthBins& bins, int width, int height, std::string_view who);

// An allocator whose memory comes zeroed from calloc and whose elements are left as they come:
// a large block is a fresh anonymous mapping whose pages the kernel maps, as zeros, when first
// written, so a large sparse array of zeros costs the pages that are written, not a memset of the
// whole. (2 MiB pages, asked for with madvise, made occlusion textures' nearest depths slower:
// each is zeroed whole on its first write.)
template <class T>
struct ZeroedAllocator {
  using value_type = T;
  ZeroedAllocator() = default;
  template <class U>
  ZeroedAllocator(const ZeroedAllocator<U>&) {}
  T* allocate(size_t n) {
    if (void* p = std::calloc(n == 0 ? 1 : n, sizeof(T))) return static_cast<T*>(p);
    throw std::bad_alloc();
  }
  void deallocate(T* p, size_t) { std::free(p); }
  template <class U>
  void construct(U*) {}  // value-initialisation: calloc's zeros
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
  template <class U>
  bool operator==(const ZeroedAllocator<U>&) const { return true; }
};

// One bit per depth bin and texel: bit k of masks[y * width + x] is set when some fragment
// through the texel centre lies in bin k (eisemann2006 §3.4's slices as packed bit channels).
// With DepthBins::nearest, also the nearest fragment of each bin through each texel centre:
// nearest[(k * height + y) * width + x] is the smallest linear depth in bin k there (depths are
// positive), 0 where bit k is clear (occlusion textures' own slice,
// docs/methods/occlusion-textures.md). Zeroed pages: slices a scene leaves empty cost nothing.
struct DepthBinMasks {
  int width = 0, height = 0;
  std::vector<uint32_t> masks;
  std::vector<float, ZeroedAllocator<float>> nearest;  // empty without DepthBins::nearest
  static uint64_t bytes(int w, int h) { return static_cast<uint64_t>(w) * static_cast<uint64_t>(h) * sizeof(uint32_t); }
  static uint64_t nearest_bytes(int w, int h, int bins) {
    return static_cast<uint64_t>(w) * static_cast<uint64_t>(h) * static_cast<uint64_t>(bins) * sizeof(float);
  }
  size_t index(int x, int y) const { return static_cast<size_t>(y) * width + x; }
  uint32_t at(int x, int y) const { return masks[index(x, y)]; }
};

// In-place compression of one texel's fragment list: `fragments` arrive sorted by z; write
// the ones to keep (or a summary, e.g. deep-shadow control points, xie2007 §5.1) to its front
// and return how many. Called exactly once per texel, empty texels included, from several
// threads at once (never two calls for the same texel).
using FragmentReducer = std::function<uint32_t(int x, int y, std::span<Fragment> fragments)>;
// Streaming access to each texel's sorted fragments (same threading rules as the reducer);
// the span is valid only during the call.
using FragmentVisitor = std::function<void(int x, int y, std::span<const Fragment> fragments)>;

// What the last call did, for benchmarks and method statistics.
struct RasterStats {
  size_t triangles = 0;   // input triangles
  size_t setup = 0;       // set-up triangles (after culling, clipping, fanning) that may cover a centre
  size_t bin_entries = 0; // (triangle, tile) pairs
  size_t fragments = 0;   // covered texel centres visited (before any depth test)
  double setup_ms = 0;    // transform, clip, bin
  double raster_ms = 0;   // tiles
};

class Rasterizer {
 public:
  // tile_size: edge of the square tiles in texels, a power of two in [8, 256]; 64 balances
  // binning overhead and load balance for 512^2-2048^2 maps.
  explicit Rasterizer(int tile_size = 64);
  ~Rasterizer();
  Rasterizer(const Rasterizer&) = delete;
  Rasterizer& operator=(const Rasterizer&) = delete;

  // The nearest surface through each texel centre (ties: the first triangle in input
  // order), with its opacity and triangle index.
  void depth_map(RasterTriangleView triangles, const LightView& view,
                 const RasterFilter& filter, DepthMap* out);

  // The options.layers nearest distinct surfaces through each texel centre, nearest first
  // (xie2007 §4.2).
  void layered_depth_map(RasterTriangleView triangles, const LightView& view,
                         const LayerOptions& options, LayeredDepthMap* out);

  // Every fragment through each texel centre, sorted by depth, in flat storage; with a
  // reducer, each texel's list as the reducer compressed it.
  void fragment_lists(RasterTriangleView triangles, const LightView& view,
                      const RasterFilter& filter, FragmentLists* out,
                      const FragmentReducer& reduce = {});

  // The same fragments, streamed texel by texel without storing the whole image's lists
  // (memory bounded by one tile's fragments per thread): for building compressed per-texel
  // structures directly.
  void visit_fragments(RasterTriangleView triangles, const LightView& view,
                       const RasterFilter& filter, const FragmentVisitor& visit);

  // Which depth bins each texel centre's fragments fall in: one pass, one bit per bin (the
  // slicing pass of eisemann2006 §3.4, where a fragment shader writes a colour channel per
  // slice). Cheaper than fragment lists: no fragment is stored or sorted.
  void depth_bin_masks(RasterTriangleView triangles, const LightView& view,
                       const RasterFilter& filter, const DepthBins& bins, DepthBinMasks* out);

  const RasterStats& stats() const { return stats_; }

  // The scratch memory a Rasterizer keeps after rendering `triangles` triangles into a
  // width x height image (for memory estimates): every triangle set up and binned, each in
  // up to two tiles on average plus a scene-sized ground plane's two in every tile. The
  // per-thread tile buffers of the fragment modes (one tile's fragments each) are left out.
  static uint64_t scratch_bytes(uint64_t triangles, int width, int height, int tile_size = 64);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int tile_size_;
  RasterStats stats_;
};

// One-shot conveniences (a fresh Rasterizer per call: fine for tests and single maps).
DepthMap render_depth_map(RasterTriangleView triangles, const LightView& view,
                          const RasterFilter& filter = {});
LayeredDepthMap render_layered_depth_map(RasterTriangleView triangles,
                                         const LightView& view, const LayerOptions& options = {});
FragmentLists render_fragment_lists(RasterTriangleView triangles,
                                    const LightView& view, const RasterFilter& filter = {},
                                    const FragmentReducer& reduce = {});

}  // namespace penumbra
