#include "penumbra/raster/rasterizer.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <type_traits>
#include <vector>

#include <tbb/enumerable_thread_specific.h>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/raster/clipping.h"
#include "penumbra/raster/raster_bins_shared.h"
#include "penumbra/raster/raster_layers_shared.h"
#include "penumbra/raster/raster_shared.h"
#include "penumbra/raster/tiling.h"

namespace penumbra {
namespace {

using raster_internal::ClipVertex;
using raster_internal::TileBinner;
using raster_internal::TileGrid;

// Input triangles per setup task: fixed, so binning order never depends on the thread count.
constexpr size_t kChunkSize = 1024;
// Snapping, edge functions and the depth plane are raster_shared.h's (the GPU rasterizer's too).
constexpr int64_t kSubpixel = shader::kRasterSubpixel;
constexpr int64_t kHalfTexel = shader::kRasterHalfTexel;

// A triangle ready to scan (shader::RasterSetup: edge functions, texel box, depth plane, source)
// and the opacity it casts with.
struct SetupTriangle : shader::RasterSetup {
  float opacity;
  bool textured;  // the source has an alpha texture: opacity varies per fragment
};

// Sets up one triangle of (unsnapped) texel-space vertices and depth values v. Returns false
// when it covers no texel centre of the image.
bool set_up(const float tx[3], const float ty[3], const double v[3], int width, int height,
            SetupTriangle* t) {
  return shader::raster_set_up({tx[0], ty[0]}, {tx[1], ty[1]}, {tx[2], ty[2]}, v[0], v[1], v[2], width, height, *t);
}

// A rectangle of texels and how to index them: texel (x, y) is element
// (y - y0) * stride + (x - x0) of the caller's storage.
struct TexelRect {
  int x0, y0, x1, y1;
  size_t stride;
  size_t index(int x, int y) const { return static_cast<size_t>(y - y0) * stride + (x - x0); }
};

// Narrows [*lo, *hi) to the x in [0, width) where the edge function e + x s is >= 0. The
// bound comes from a floating-point quotient, then is corrected with exact integer evaluations,
// so the span is exactly the set the per-texel test would accept.
inline void clip_span(int64_t e, int64_t s, double inv_s, int width, int* lo, int* hi) {
  if (s > 0) {
    if (e >= 0) return;
    double q = static_cast<double>(-e) * inv_s;  // first x inside: ceil(q)
    if (q >= width) {
      *hi = 0;
      return;
    }
    int64_t n = static_cast<int64_t>(q);
    if (static_cast<double>(n) < q) ++n;
    while (e + n * s < 0) ++n;
    while (n > 0 && e + (n - 1) * s >= 0) --n;
    *lo = std::max(*lo, static_cast<int>(n));
  } else if (s < 0) {
    if (e < 0) {
      *hi = 0;
      return;
    }
    double q = static_cast<double>(e) * -inv_s;  // last x inside: floor(q)
    if (q >= width) return;
    int64_t n = static_cast<int64_t>(q);
    while (n >= 0 && e + n * s < 0) --n;
    while (e + (n + 1) * s >= 0) ++n;
    *hi = std::min(*hi, static_cast<int>(n + 1));
  } else if (e < 0) {
    *hi = 0;
  }
}

// Calls fn(index, v, x, y) for every texel centre (x, y) of r that t covers, row by row, with
// incremental edge functions. Narrow boxes test every texel; wider ones compute each row's
// span first.
template <class Fn>
inline void scan(const SetupTriangle& t, const TexelRect& r, Fn&& fn) {
  const int x0 = std::max(r.x0, t.x0), x1 = std::min(r.x1, t.x1);
  const int y0 = std::max(r.y0, t.y0), y1 = std::min(r.y1, t.y1);
  if (x0 >= x1 || y0 >= y1) return;
  const int64_t px = x0 * kSubpixel + kHalfTexel, py = y0 * kSubpixel + kHalfTexel;
  int64_t e0 = t.a0 * px + t.b0 * py + t.c0;
  int64_t e1 = t.a1 * px + t.b1 * py + t.c1;
  int64_t e2 = t.a2 * px + t.b2 * py + t.c2;
  const int64_t sx0 = t.a0 * kSubpixel, sx1 = t.a1 * kSubpixel, sx2 = t.a2 * kSubpixel;
  const int64_t sy0 = t.b0 * kSubpixel, sy1 = t.b1 * kSubpixel, sy2 = t.b2 * kSubpixel;
  const float vx0 = t.v0 + t.dvdx * static_cast<float>(x0 - t.x0);
  const int width = x1 - x0;
  size_t row = r.index(x0, y0);
  if (width <= 4) {
    for (int y = y0; y < y1; ++y, row += r.stride) {
      int64_t f0 = e0, f1 = e1, f2 = e2;
      const float vrow = vx0 + t.dvdy * static_cast<float>(y - t.y0);
      for (int x = 0; x < width; ++x) {
        if ((f0 | f1 | f2) >= 0) fn(row + x, vrow + t.dvdx * static_cast<float>(x), x0 + x, y);  // all >= 0
        f0 += sx0; f1 += sx1; f2 += sx2;
      }
      e0 += sy0; e1 += sy1; e2 += sy2;
    }
    return;
  }
  const double inv0 = sx0 ? 1.0 / static_cast<double>(sx0) : 0.0;
  const double inv1 = sx1 ? 1.0 / static_cast<double>(sx1) : 0.0;
  const double inv2 = sx2 ? 1.0 / static_cast<double>(sx2) : 0.0;
  for (int y = y0; y < y1; ++y, row += r.stride) {
    int lo = 0, hi = width;
    clip_span(e0, sx0, inv0, width, &lo, &hi);
    clip_span(e1, sx1, inv1, width, &lo, &hi);
    clip_span(e2, sx2, inv2, width, &lo, &hi);
    const float vrow = vx0 + t.dvdy * static_cast<float>(y - t.y0);
    for (int x = lo; x < hi; ++x) fn(row + x, vrow + t.dvdx * static_cast<float>(x), x0 + x, y);
    e0 += sy0; e1 += sy1; e2 += sy2;
  }
}

// The opacity of each fragment of a textured triangle (issue 20): the view's ray through the
// texel centre meets the source triangle, whose alpha texture is looked up there.
struct FragmentAlpha {
  RasterTriangleView triangles;
  const LightView* view = nullptr;
  float operator()(uint32_t source, int x, int y) const {
    const LightView::TexelRay r = view->texel_ray({static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f});
    return triangles.opacity_on_line(triangles[source], r.origin, r.dir);
  }
};

// Calls fn(index, v, opacity) for every fragment of t in r that has some opacity: a triangle
// without an alpha texture gives every fragment its opacity; a textured one drops the
// fragments in the holes of its mask (xie2007 §5's fragments carry what is left).
template <class Fn>
inline void scan_fragments(const SetupTriangle& t, const TexelRect& r, const FragmentAlpha& alpha, Fn&& fn) {
  if (!t.textured) {
    const float a = t.opacity;
    scan(t, r, [&](size_t i, float v, int, int) { fn(i, v, a); });
    return;
  }
  scan(t, r, [&](size_t i, float v, int x, int y) {
    const float a = alpha(t.source, x, y);
    if (a > 0) fn(i, v, a);
  });
}

// scan_fragments with the texel's coordinates: fn(i, v, x, y).
template <class Fn>
inline void scan_fragments_at(const SetupTriangle& t, const TexelRect& r, const FragmentAlpha& alpha, Fn&& fn) {
  scan(t, r, [&](size_t i, float v, int x, int y) {
    if (!t.textured || alpha(t.source, x, y) > 0) fn(i, v, x, y);
  });
}

// v -> linear depth, kept inside [near, far] (a centre covered only thanks to snapping, or
// float error, can extrapolate a hair beyond the clipped triangle).
template <bool kPerspective>
inline float linear_depth(float v, float near, float far) {
  return shader::raster_linear_depth(v, near, far, kPerspective);
}

template <class F>
void dispatch_projection(const LightView& view, F&& f) {
  if (view.is_perspective())
    f(std::true_type{});
  else
    f(std::false_type{});
}

// Fragments sort by (z, triangle) as one unsigned 64-bit key, computed once per fragment
// (raster_shared.h raster_depth_key): ties in z keep triangle (input) order.
inline uint64_t sort_key(float z, uint32_t triangle) { return shader::raster_depth_key(z, triangle); }
inline float key_depth(uint64_t key) { return shader::raster_key_depth(key); }

struct KeyedFragment {
  uint64_t key;
  float opacity;
  uint32_t texel;  // within the tile, row-major
};

struct TileScratch {
  std::vector<KeyedFragment> gathered;  // in triangle order
  std::vector<KeyedFragment> sorted;    // grouped by texel, each group sorted by key
  std::vector<uint32_t> offsets;        // per local texel: start in sorted (prefix sums)
  std::vector<Fragment> fragments;      // `sorted` as Fragments, for visit_fragments
};

void sort_by_key(KeyedFragment* f, size_t n) {
  if (n <= 32) {  // insertion sort: lists are short in almost every texel
    for (size_t i = 1; i < n; ++i) {
      KeyedFragment x = f[i];
      size_t j = i;
      for (; j > 0 && x.key < f[j - 1].key; --j) f[j] = f[j - 1];
      f[j] = x;
    }
  } else {
    std::sort(f, f + n, [](const KeyedFragment& a, const KeyedFragment& b) { return a.key < b.key; });
  }
}

}  // namespace

struct Rasterizer::Impl {
  TileBinner<SetupTriangle> binner;
  TileGrid grid;
  tbb::enumerable_thread_specific<TileScratch> scratch;
  std::vector<std::vector<Fragment>> tile_fragments;  // fragment_lists: each tile's output
  std::vector<uint32_t> counts;                       // fragment_lists: per texel
  std::atomic<size_t> fragments{0};
  FragmentAlpha alpha;  // the current call's triangles and view

  // Culls, clips, sets up and bins every triangle.
  void set_up_triangles(RasterTriangleView tris, const LightView& view,
                        const RasterFilter& filter, int tile_size);
  // Collects the fragments of one tile into *out, grouped by texel (row-major within the
  // tile) and sorted by depth: s.offsets[k] .. s.offsets[k + 1] index *out for local texel k.
  template <bool kPerspective>
  void gather_tile(int tile, const LightView& view, TileScratch& s, std::vector<Fragment>* out);
};

void Rasterizer::Impl::set_up_triangles(RasterTriangleView tris, const LightView& view,
                                        const RasterFilter& filter, int tile_size) {
  grid = TileGrid(view.width(), view.height(), raster_internal::tile_shift(tile_size));
  alpha = FragmentAlpha{tris, &view};
  const bool perspective = view.is_perspective();
  const raster_internal::TriangleClipper clipper(view);
  binner.run(tris.size(), kChunkSize, grid, [&](size_t, size_t begin, size_t end, std::vector<SetupTriangle>& out) {
    ClipVertex poly[raster_internal::kMaxClipVertices];
    float tx[raster_internal::kMaxClipVertices], ty[raster_internal::kMaxClipVertices];
    double v[raster_internal::kMaxClipVertices];
    for (size_t i = begin; i < end; ++i) {
      const RasterTriangle& tri = tris[i];
      if (!(tri.opacity > 0) || (filter.opaque_only && tris.semi_transparent(tri))) continue;
      if (filter.culling != FaceCulling::None) {
        bool front = raster_internal::faces_light(tri, view);
        if (front != (filter.culling == FaceCulling::Back)) continue;
      }
      int n = clipper.clip(tri, poly);
      for (int k = 0; k < n; ++k) {
        tx[k] = poly[k].x / poly[k].w;
        ty[k] = poly[k].y / poly[k].w;
        v[k] = perspective ? 1.0 / poly[k].w : poly[k].z;
      }
      // A clipped polygon becomes a fan; shared fan edges follow the fill rule like any other.
      for (int k = 1; k + 1 < n; ++k) {
        float fx[3] = {tx[0], tx[k], tx[k + 1]}, fy[3] = {ty[0], ty[k], ty[k + 1]};
        double fv[3] = {v[0], v[k], v[k + 1]};
        SetupTriangle st;
        if (!set_up(fx, fy, fv, view.width(), view.height(), &st)) continue;
        st.opacity = tri.opacity;
        st.source = static_cast<uint32_t>(i);
        st.textured = tris.textured(tri);
        out.push_back(st);
      }
    }
  });
}

template <bool kPerspective>
void Rasterizer::Impl::gather_tile(int tile, const LightView& view, TileScratch& s,
                                   std::vector<Fragment>* fragments_out) {
  const int x0 = grid.x0(tile), y0 = grid.y0(tile), x1 = grid.x1(tile), y1 = grid.y1(tile);
  const int tw = x1 - x0, texels = tw * (y1 - y0);
  const TexelRect rect{x0, y0, x1, y1, static_cast<size_t>(tw)};
  const float near = view.near(), far = view.far();
  s.gathered.clear();
  for (const SetupTriangle& t : binner.tile(tile)) {
    const uint32_t source = t.source;
    scan_fragments(t, rect, alpha, [&](size_t k, float v, float opacity) {
      float z = linear_depth<kPerspective>(v, near, far);
      s.gathered.push_back({sort_key(z, source), opacity, static_cast<uint32_t>(k)});
    });
  }
  const size_t n = s.gathered.size();
  fragments.fetch_add(n, std::memory_order_relaxed);
  // Counting sort by texel (stable: keeps triangle order), then sort each texel by depth.
  s.offsets.assign(static_cast<size_t>(texels) + 1, 0);
  for (const KeyedFragment& f : s.gathered) ++s.offsets[f.texel + 1];
  for (int k = 0; k < texels; ++k) s.offsets[k + 1] += s.offsets[k];
  s.sorted.resize(n);
  for (const KeyedFragment& f : s.gathered) s.sorted[s.offsets[f.texel]++] = f;
  for (int k = texels; k > 0; --k) s.offsets[k] = s.offsets[k - 1];  // undo the cursor advance
  s.offsets[0] = 0;
  fragments_out->resize(n);
  for (int k = 0; k < texels; ++k) {
    KeyedFragment* f = s.sorted.data() + s.offsets[k];
    size_t m = s.offsets[k + 1] - s.offsets[k];
    sort_by_key(f, m);
    Fragment* out = fragments_out->data() + s.offsets[k];
    for (size_t i = 0; i < m; ++i)
      out[i] = {key_depth(f[i].key), f[i].opacity, static_cast<uint32_t>(f[i].key)};
  }
}

uint64_t Rasterizer::scratch_bytes(uint64_t triangles, int width, int height, int tile_size) {
  const TileGrid grid(width, height, std::max(0, raster_internal::tile_shift(tile_size)));
  const uint64_t entries = 2 * triangles + 2 * static_cast<uint64_t>(grid.count());
  return TileBinner<SetupTriangle>::bytes(triangles, kChunkSize, grid, triangles, entries);
}

Rasterizer::Rasterizer(int tile_size) : impl_(std::make_unique<Impl>()), tile_size_(tile_size) {
  if (raster_internal::tile_shift(tile_size) < 0)
    throw Error("Rasterizer: tile size {} must be a power of two in [8, 256]", tile_size);
}

Rasterizer::~Rasterizer() = default;

void Rasterizer::depth_map(RasterTriangleView triangles, const LightView& view,
                           const RasterFilter& filter, DepthMap* out) {
  Timer timer;
  Impl& im = *impl_;
  im.set_up_triangles(triangles, view, filter, tile_size_);
  stats_ = {};
  stats_.setup_ms = timer.elapsed_ms();
  timer.reset();
  out->resize(view.width(), view.height());
  im.fragments = 0;
  const int width = view.width();
  dispatch_projection(view, [&](auto perspective) {
    constexpr bool kPerspective = decltype(perspective)::value;
    const float near = view.near(), far = view.far();
    raster_internal::for_each_tile(im.grid, [&](int tile) {
      const int x0 = im.grid.x0(tile), y0 = im.grid.y0(tile), x1 = im.grid.x1(tile), y1 = im.grid.y1(tile);
      for (int y = y0; y < y1; ++y) {
        size_t row = static_cast<size_t>(y) * width;
        std::fill(out->z.begin() + row + x0, out->z.begin() + row + x1, kInfinity);
        std::fill(out->opacity.begin() + row + x0, out->opacity.begin() + row + x1, 0.0f);
        std::fill(out->triangle.begin() + row + x0, out->triangle.begin() + row + x1, kNoTriangle);
      }
      size_t frags = 0;
      const TexelRect rect{x0, y0, x1, y1, static_cast<size_t>(width)};
      // Index the whole image from the tile's rectangle.
      float* z = out->z.data() + rect.y0 * rect.stride + rect.x0;
      float* opacity = out->opacity.data() + rect.y0 * rect.stride + rect.x0;
      uint32_t* tri = out->triangle.data() + rect.y0 * rect.stride + rect.x0;
      for (const SetupTriangle& t : im.binner.tile(tile)) {
        const uint32_t source = t.source;
        scan_fragments(t, rect, im.alpha, [&](size_t i, float v, float a) {
          ++frags;
          float zf = linear_depth<kPerspective>(v, near, far);
          if (zf < z[i]) {  // strict: on equal depth the first triangle in input order stays
            z[i] = zf;
            opacity[i] = a;
            tri[i] = source;
          }
        });
      }
      float* depth = out->depth.data() + rect.y0 * rect.stride + rect.x0;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          size_t i = rect.index(x, y);
          depth[i] = tri[i] != kNoTriangle ? view.window_depth(z[i]) : kInfinity;
        }
      im.fragments.fetch_add(frags, std::memory_order_relaxed);
    });
  });
  stats_.triangles = triangles.size();
  stats_.setup = im.binner.item_count();
  stats_.bin_entries = im.binner.entry_count();
  stats_.fragments = im.fragments;
  stats_.raster_ms = timer.elapsed_ms();
}

// Layers per texel, xie2007 §4.2 (the rule for distinct surfaces: raster_layers_shared.h, which the
// GPU's peeling shares): "if a z sample is closer than any of the existing k samples
// in a pixel, it is inserted into the list". Distinct surfaces: a fragment within
// distinct_epsilon of a layer's front (its nearest fragment) joins that layer; a fragment
// that lies in front of a layer but within epsilon of it becomes that layer's new front. The
// result is the first k layers of the sorted fragments grouped greedily from the front (a
// fragment starts a new layer when it lies more than epsilon behind the current layer's
// front) whenever no single layer holds fragments spread over more than epsilon - that is,
// whenever coincident geometry is tighter than epsilon and distinct surfaces are farther apart
// than epsilon. Otherwise (a chain of fragments each within epsilon of the next) the result
// can depend on the input order. A merged layer keeps the front's depth and triangle and
// composes the opacities, 1 - prod(1 - a_i): what a ray crossing the coincident sheets keeps.
void Rasterizer::layered_depth_map(RasterTriangleView triangles, const LightView& view,
                                   const LayerOptions& options, LayeredDepthMap* out) {
  if (options.layers < 1 || options.layers > 255) throw Error("Rasterizer: layers = {} must be in [1, 255]", options.layers);
  if (!(options.distinct_epsilon >= 0)) throw Error("Rasterizer: distinct_epsilon must be >= 0");
  Timer timer;
  Impl& im = *impl_;
  im.set_up_triangles(triangles, view, options.filter, tile_size_);
  stats_ = {};
  stats_.setup_ms = timer.elapsed_ms();
  timer.reset();
  const int k = options.layers;
  out->resize(view.width(), view.height(), k);
  im.fragments = 0;
  const int width = view.width();
  const float eps = options.distinct_epsilon;
  dispatch_projection(view, [&](auto perspective) {
    constexpr bool kPerspective = decltype(perspective)::value;
    const float near = view.near(), far = view.far();
    raster_internal::for_each_tile(im.grid, [&](int tile) {
      const int x0 = im.grid.x0(tile), y0 = im.grid.y0(tile), x1 = im.grid.x1(tile), y1 = im.grid.y1(tile);
      for (int y = y0; y < y1; ++y) {
        size_t row = static_cast<size_t>(y) * width;
        std::fill(out->counts.begin() + row + x0, out->counts.begin() + row + x1, uint8_t{0});
      }
      size_t frags = 0;
      const TexelRect rect{x0, y0, x1, y1, static_cast<size_t>(width)};
      uint8_t* counts = out->counts.data() + rect.y0 * rect.stride + rect.x0;
      DepthSample* samples = out->samples.data() + (rect.y0 * rect.stride + rect.x0) * k;
      for (const SetupTriangle& t : im.binner.tile(tile)) {
        const uint32_t source = t.source;
        scan_fragments(t, rect, im.alpha, [&](size_t i, float v, float a) {
          ++frags;
          const float z = linear_depth<kPerspective>(v, near, far);
          DepthSample* s = samples + i * k;
          int n = counts[i];
          // Most fragments of a deep texel lie behind a full list: reject them first.
          if (n == k && shader::raster_layer_behind(z, s[n - 1].z, eps)) return;
          int p = n;
          while (p > 0 && s[p - 1].z > z) --p;  // s[p-1].z <= z < s[p].z
          if (p > 0 && !shader::raster_layer_behind(z, s[p - 1].z, eps)) {  // joins the layer in front
            s[p - 1].opacity = shader::raster_layer_opacity(s[p - 1].opacity, a);
            return;
          }
          if (p < n && !shader::raster_layer_behind(s[p].z, z, eps)) {  // becomes the front of the layer behind
            s[p].z = z;
            s[p].triangle = source;
            s[p].opacity = shader::raster_layer_opacity(s[p].opacity, a);
            return;
          }
          if (p == k) return;
          // Insert at p, pushing the layers behind back by one (the k-th falls off a full
          // list). A carried swap: lists are a few samples long, and a shifting loop would be
          // turned into a memmove call.
          const int end = std::min(n + 1, k);
          DepthSample carry{z, 0, a, source};
          for (int q = p; q < end; ++q) std::swap(carry, s[q]);
          counts[i] = static_cast<uint8_t>(end);
        });
      }
      // Window depths of the layers present. Unused layers are left as they were: clearing
      // k samples per texel would cost more memory traffic than the whole single-layer map,
      // where xie2007 §4.2 finds a 5-layer map only ~5% dearer than one layer.
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          size_t i = rect.index(x, y);
          DepthSample* s = samples + i * k;
          for (int l = 0, n = counts[i]; l < n; ++l) s[l].depth = view.window_depth(s[l].z);
        }
      im.fragments.fetch_add(frags, std::memory_order_relaxed);
    });
  });
  stats_.triangles = triangles.size();
  stats_.setup = im.binner.item_count();
  stats_.bin_entries = im.binner.entry_count();
  stats_.fragments = im.fragments;
  stats_.raster_ms = timer.elapsed_ms();
}

void Rasterizer::fragment_lists(RasterTriangleView triangles, const LightView& view,
                                const RasterFilter& filter, FragmentLists* out,
                                const FragmentReducer& reduce) {
  Timer timer;
  Impl& im = *impl_;
  im.set_up_triangles(triangles, view, filter, tile_size_);
  stats_ = {};
  stats_.setup_ms = timer.elapsed_ms();
  timer.reset();
  const int width = view.width(), height = view.height();
  out->width = width;
  out->height = height;
  const size_t texels = static_cast<size_t>(width) * height;
  out->offsets.resize(texels + 1);
  im.fragments = 0;
  if (im.tile_fragments.size() < static_cast<size_t>(im.grid.count())) im.tile_fragments.resize(im.grid.count());
  im.counts.resize(texels);
  // Pass 1, per tile: gather, sort, reduce; keep the tile's lists and each texel's count.
  dispatch_projection(view, [&](auto perspective) {
    constexpr bool kPerspective = decltype(perspective)::value;
    raster_internal::for_each_tile(im.grid, [&](int tile) {
      TileScratch& s = im.scratch.local();
      std::vector<Fragment>& kept = im.tile_fragments[tile];
      im.gather_tile<kPerspective>(tile, view, s, &kept);
      const int x0 = im.grid.x0(tile), y0 = im.grid.y0(tile), x1 = im.grid.x1(tile), y1 = im.grid.y1(tile);
      // Reduce each list in place and compact the tile's storage (the write position never
      // passes the read position).
      size_t write = 0;
      int k = 0;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x, ++k) {
          std::span<Fragment> list(kept.data() + s.offsets[k], s.offsets[k + 1] - s.offsets[k]);
          uint32_t n = static_cast<uint32_t>(list.size());
          if (reduce) n = std::min(n, reduce(x, y, list));
          if (write != s.offsets[k]) std::copy(list.begin(), list.begin() + n, kept.begin() + write);
          write += n;
          im.counts[static_cast<size_t>(y) * width + x] = n;
        }
      kept.resize(write);
    });
  });
  // Pass 2: prefix sum of the counts (row sums in parallel, then rows in order).
  std::vector<uint64_t> row_start(static_cast<size_t>(height) + 1, 0);
  const uint32_t* counts = im.counts.data();
  parallel_for(height, 1, [&](size_t begin, size_t end) {
    for (int y = static_cast<int>(begin); y < static_cast<int>(end); ++y) {
      uint64_t sum = 0;
      for (int x = 0; x < width; ++x) sum += counts[static_cast<size_t>(y) * width + x];
      row_start[y + 1] = sum;
    }
  });
  for (int y = 0; y < height; ++y) row_start[y + 1] += row_start[y];
  if (row_start[height] > 0xffffffffull) throw Error("Rasterizer: {} fragments overflow 32-bit offsets", row_start[height]);
  parallel_for(height, 1, [&](size_t begin, size_t end) {
    for (int y = static_cast<int>(begin); y < static_cast<int>(end); ++y) {
      size_t row = static_cast<size_t>(y) * width;
      uint32_t sum = static_cast<uint32_t>(row_start[y]);
      for (int x = 0; x < width; ++x) {
        out->offsets[row + x] = sum;
        sum += counts[row + x];
      }
    }
  });
  out->offsets[texels] = static_cast<uint32_t>(row_start[height]);
  // Pass 3: scatter each tile's lists to their place.
  out->fragments.resize(row_start[height]);
  raster_internal::for_each_tile(im.grid, [&](int tile) {
    const int x0 = im.grid.x0(tile), y0 = im.grid.y0(tile), x1 = im.grid.x1(tile), y1 = im.grid.y1(tile);
    const Fragment* src = im.tile_fragments[tile].data();
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        size_t i = static_cast<size_t>(y) * width + x;
        uint32_t n = out->offsets[i + 1] - out->offsets[i];
        std::copy(src, src + n, out->fragments.begin() + out->offsets[i]);
        src += n;
      }
  });
  stats_.triangles = triangles.size();
  stats_.setup = im.binner.item_count();
  stats_.bin_entries = im.binner.entry_count();
  stats_.fragments = im.fragments;
  stats_.raster_ms = timer.elapsed_ms();
}

void Rasterizer::visit_fragments(RasterTriangleView triangles, const LightView& view,
                                 const RasterFilter& filter, const FragmentVisitor& visit) {
  Timer timer;
  Impl& im = *impl_;
  im.set_up_triangles(triangles, view, filter, tile_size_);
  stats_ = {};
  stats_.setup_ms = timer.elapsed_ms();
  timer.reset();
  im.fragments = 0;
  dispatch_projection(view, [&](auto perspective) {
    constexpr bool kPerspective = decltype(perspective)::value;
    raster_internal::for_each_tile(im.grid, [&](int tile) {
      TileScratch& s = im.scratch.local();
      im.gather_tile<kPerspective>(tile, view, s, &s.fragments);
      const int x0 = im.grid.x0(tile), y0 = im.grid.y0(tile), x1 = im.grid.x1(tile), y1 = im.grid.y1(tile);
      int k = 0;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x, ++k)
          visit(x, y, std::span<const Fragment>(s.fragments.data() + s.offsets[k], s.offsets[k + 1] - s.offsets[k]));
    });
  });
  stats_.triangles = triangles.size();
  stats_.setup = im.binner.item_count();
  stats_.bin_entries = im.binner.entry_count();
  stats_.fragments = im.fragments;
  stats_.raster_ms = timer.elapsed_ms();
}

TileDepthBins tile_depth_bins(const DepthBins& bins, int width, int height, std::string_view who) {
  TileDepthBins out;
  if (bins.tiles.empty()) return out;
  const int side = bins.tile_side;
  if (side < 1 || !std::has_single_bit(static_cast<unsigned>(side)))
    throw Error("{}: the depth bins' tile side {} must be a power of two", who, side);
  out.shift = std::countr_zero(static_cast<unsigned>(side));
  out.columns = (width + side - 1) / side;
  const size_t rows = static_cast<size_t>((height + side - 1) / side);
  if (bins.tiles.size() != rows * out.columns)
    throw Error("{}: {} tiles of depth bins for a {} x {} image of {}-texel tiles ({} needed)", who, bins.tiles.size(),
                width, height, side, rows * out.columns);
  out.records.reserve(bins.tiles.size());
  for (Vec2f t : bins.tiles) {
    if (!(t.y > 0) || !std::isfinite(t.x) || !std::isfinite(t.y))
      throw Error("{}: a tile's depth bins need a finite start and a positive width", who);
    out.records.push_back(shader::raster_depth_bins(t.x, t.y, bins.count));
  }
  return out;
}

void Rasterizer::depth_bin_masks(RasterTriangleView triangles, const LightView& view,
                                 const RasterFilter& filter, const DepthBins& bins, DepthBinMasks* out) {
  if (bins.count < 1 || bins.count > 32) throw Error("Rasterizer: {} depth bins must be in [1, 32]", bins.count);
  if (!(bins.width > 0) || !std::isfinite(bins.first)) throw Error("Rasterizer: depth bins need a finite start and a positive width");
  const TileDepthBins tile_bins = tile_depth_bins(bins, view.width(), view.height(), "Rasterizer");
  Timer timer;
  Impl& im = *impl_;
  im.set_up_triangles(triangles, view, filter, tile_size_);
  stats_ = {};
  stats_.setup_ms = timer.elapsed_ms();
  timer.reset();
  const int width = view.width();
  out->width = width;
  out->height = view.height();
  out->masks.resize(static_cast<size_t>(width) * view.height());
  const size_t plane = static_cast<size_t>(width) * view.height();
  // Zeros where no fragment is: an array of the same size is cleared in parallel; a new one comes
  // from zeroed pages, of which only those a bin covers are ever written.
  const size_t nearest_size = bins.nearest ? plane * static_cast<size_t>(bins.count) : 0;
  if (out->nearest.size() == nearest_size) {
    parallel_for(nearest_size, size_t{1} << 18, [&](size_t b, size_t e) {
      std::fill(out->nearest.begin() + b, out->nearest.begin() + e, 0.0f);
    });
  } else {
    decltype(out->nearest)().swap(out->nearest);
    out->nearest.resize(nearest_size);
  }
  im.fragments = 0;
  const shader::RasterDepthBins depth_bins = shader::raster_depth_bins(bins.first, bins.width, bins.count);
  dispatch_projection(view, [&](auto perspective) {
    constexpr bool kPerspective = decltype(perspective)::value;
    const float near = view.near(), far = view.far();
    raster_internal::for_each_tile(im.grid, [&](int tile) {
      const int x0 = im.grid.x0(tile), y0 = im.grid.y0(tile), x1 = im.grid.x1(tile), y1 = im.grid.y1(tile);
      const TexelRect rect{x0, y0, x1, y1, static_cast<size_t>(width)};
      uint32_t* masks = out->masks.data() + rect.y0 * rect.stride + rect.x0;
      for (int y = y0; y < y1; ++y) std::fill(masks + rect.index(x0, y), masks + rect.index(x1, y), 0u);
      // The bins' nearest depths: bin k's plane at nearest + k * plane, the tile's corner as masks'
      // (0: none yet; the depths are positive).
      float* nearest = bins.nearest ? out->nearest.data() + rect.y0 * rect.stride + rect.x0 : nullptr;
      auto keep_nearest = [&](size_t i, int k, float z) {
        float& n = nearest[static_cast<size_t>(k) * plane + i];
        if (n == 0.0f || z < n) n = z;
      };
      size_t frags = 0;
      // Per-tile bins: one record when this raster tile lies in one bins tile, else one per texel.
      shader::RasterDepthBins tile_record = depth_bins;
      bool per_texel = false;
      if (!tile_bins.records.empty()) {
        const int s = tile_bins.shift;
        per_texel = (x0 >> s) != ((x1 - 1) >> s) || (y0 >> s) != ((y1 - 1) >> s);
        tile_record = tile_bins.records[shader::raster_bins_tile(x0, y0, s, tile_bins.columns)];
      }
      if (per_texel) {
        for (const SetupTriangle& t : im.binner.tile(tile))
          scan_fragments_at(t, rect, im.alpha, [&](size_t i, float v, int x, int y) {
            ++frags;
            const shader::RasterDepthBins& b =
                tile_bins.records[shader::raster_bins_tile(x, y, tile_bins.shift, tile_bins.columns)];
            const float z = linear_depth<kPerspective>(v, near, far);
            const int k = shader::raster_depth_bin(b, z);
            masks[i] |= 1u << k;
            if (nearest) keep_nearest(i, k, z);
          });
        im.fragments.fetch_add(frags, std::memory_order_relaxed);
        return;
      }
      auto bin = [&](float v) { return shader::raster_depth_bin(tile_record, linear_depth<kPerspective>(v, near, far)); };
      for (const SetupTriangle& t : im.binner.tile(tile)) {
        // Most triangles are far thinner than a bin: when the depth plane over the triangle's
        // texel box (with a margin far above float rounding) lies in one bin, every fragment
        // sets that bit without its own depth (unless the bins' nearest depths are kept).
        const float ex = t.dvdx * static_cast<float>(t.x1 - 1 - t.x0), ey = t.dvdy * static_cast<float>(t.y1 - 1 - t.y0);
        const float lo = t.v0 + std::min(0.0f, ex) + std::min(0.0f, ey), hi = t.v0 + std::max(0.0f, ex) + std::max(0.0f, ey);
        const float margin = 1e-5f * std::max(std::abs(lo), std::abs(hi));
        const int k_lo = bin(lo - margin), k_hi = bin(hi + margin);
        if (k_lo == k_hi && !nearest) {
          const uint32_t bit = 1u << k_lo;
          scan_fragments(t, rect, im.alpha, [&](size_t i, float, float) {
            ++frags;
            masks[i] |= bit;
          });
          continue;
        }
        scan_fragments(t, rect, im.alpha, [&](size_t i, float v, float) {
          ++frags;
          const float z = linear_depth<kPerspective>(v, near, far);
          const int k = shader::raster_depth_bin(tile_record, z);
          masks[i] |= 1u << k;
          if (nearest) keep_nearest(i, k, z);
        });
      }
      im.fragments.fetch_add(frags, std::memory_order_relaxed);
    });
  });
  stats_.triangles = triangles.size();
  stats_.setup = im.binner.item_count();
  stats_.bin_entries = im.binner.entry_count();
  stats_.fragments = im.fragments;
  stats_.raster_ms = timer.elapsed_ms();
}

namespace {
// Exactly n elements: a map reused for views whose size varies (one per light sample) must
// not take vector::resize's doubled capacity, nor copy the old texels while growing (the
// rasterizer writes every texel anew), so it never holds more than its largest view
// (what the memory estimates count, DepthMap::bytes).
template <class T>
void resize_exact(std::vector<T>& v, size_t n) {
  if (n > v.capacity()) std::vector<T>().swap(v);
  v.resize(n);
}
}  // namespace

void DepthMap::resize(int w, int h) {
  width = w;
  height = h;
  size_t n = static_cast<size_t>(w) * h;
  resize_exact(z, n);
  resize_exact(depth, n);
  resize_exact(opacity, n);
  resize_exact(triangle, n);
}

void LayeredDepthMap::resize(int w, int h, int layers) {
  width = w;
  height = h;
  max_layers = layers;
  size_t n = static_cast<size_t>(w) * h;
  resize_exact(counts, n);
  resize_exact(samples, n * layers);
}

DepthMap render_depth_map(RasterTriangleView triangles, const LightView& view,
                          const RasterFilter& filter) {
  DepthMap out;
  Rasterizer().depth_map(triangles, view, filter, &out);
  return out;
}

LayeredDepthMap render_layered_depth_map(RasterTriangleView triangles,
                                         const LightView& view, const LayerOptions& options) {
  LayeredDepthMap out;
  Rasterizer().layered_depth_map(triangles, view, options, &out);
  return out;
}

FragmentLists render_fragment_lists(RasterTriangleView triangles,
                                    const LightView& view, const RasterFilter& filter,
                                    const FragmentReducer& reduce) {
  FragmentLists out;
  Rasterizer().fragment_lists(triangles, view, filter, &out, reduce);
  return out;
}

}  // namespace penumbra
