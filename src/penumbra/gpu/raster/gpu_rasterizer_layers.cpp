// The GPU rasterizer's layered depth maps and fragment lists (gpu_raster_modes.h; layouts and
// kernels in raster_modes_shared.h): the depth map's set-up and scan, other fills and resolves.
#include <algorithm>
#include <cstddef>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/gpu/raster/gpu_rasterizer.h"
#include "penumbra/gpu/raster/raster_modes_shared.h"

namespace penumbra::gpu {
namespace {

using shader::GpuRasterState;

constexpr uint32_t kMinusInfinityBits = 0xff800000u;
constexpr uint64_t kLayerSampleBytes = 16;  // z, window depth, opacity, triangle
constexpr uint64_t kFragmentBytes = sizeof(shader::GpuFragment);

uint64_t texel_count(int w, int h) { return static_cast<uint64_t>(w) * static_cast<uint64_t>(h); }

}  // namespace

void GpuLayeredDepthMap::resize(Device& device, int w, int h, int k) {
  if (w == width_ && h == height_ && k == k_ && !keys_.empty()) return;
  const uint64_t n = texel_count(w, h);
  keys_ = Buffer();
  samples_ = Buffer();
  keys_ = Buffer(device, n * 8, "a layered depth map's keys");
  front_ = Buffer(device, n * 4, "a layered depth map's fronts");
  counts_ = Buffer(device, n * 4, "a layered depth map's counts");
  samples_ = Buffer(device, n * static_cast<uint64_t>(k) * kLayerSampleBytes, "a layered depth map's layers");
  width_ = w;
  height_ = h;
  k_ = k;
}

uint64_t GpuLayeredDepthMap::bytes(int w, int h, int k) {
  return texel_count(w, h) * (8 + 4 + 4 + static_cast<uint64_t>(k) * kLayerSampleBytes) + sizeof(shader::RasterView);
}

uint64_t GpuLayeredDepthMap::device_bytes() const {
  uint64_t total = 0;
  for (const Buffer* b : {&keys_, &front_, &counts_, &samples_, &view_record_}) total += b->bytes();
  return total;
}

LayeredDepthMap GpuLayeredDepthMap::download() const {
  LayeredDepthMap m;
  m.resize(width_, height_, k_);
  const uint64_t n = texel_count(width_, height_);
  const std::vector<uint32_t> counts = counts_.download_vector<uint32_t>(n);
  for (uint64_t i = 0; i < n; ++i) m.counts[i] = static_cast<uint8_t>(counts[i]);
  static_assert(sizeof(DepthSample) == kLayerSampleBytes);
  samples_.download(m.samples.data(), n * static_cast<uint64_t>(k_) * kLayerSampleBytes);
  return m;
}

void GpuFragmentLists::resize(Device& device, int w, int h) {
  if (w == width_ && h == height_ && !counts_.empty()) return;
  const uint64_t n = texel_count(w, h);
  counts_ = Buffer(device, n * 4, "fragment lists' counts");
  offsets_ = Buffer(device, (n + 1) * 4, "fragment lists' offsets");
  width_ = w;
  height_ = h;
}

void GpuFragmentLists::reserve(Device& device, uint64_t fragments) {
  if (fragments <= capacity_ && !fragments_.empty()) return;
  if (fragments > 0xffffffffull)
    throw Error("GPU rasterizer: {} fragments are more than one map's lists can index (at most {})", fragments,
                0xffffffffull);
  fragments_ = Buffer();
  fragments_ = Buffer(device, std::max<uint64_t>(1, fragments) * kFragmentBytes, "the fragment lists");
  capacity_ = static_cast<uint32_t>(fragments);
}

uint64_t GpuFragmentLists::bytes(int w, int h, uint64_t fragments) {
  const uint64_t n = texel_count(w, h);
  return n * 4 + (n + 1) * 4 + fragments * kFragmentBytes + GpuScan::scratch_bytes(n) + sizeof(shader::RasterView);
}

uint64_t GpuFragmentLists::device_bytes() const {
  uint64_t total = scan_.device_bytes();
  for (const Buffer* b : {&counts_, &offsets_, &fragments_, &view_record_}) total += b->bytes();
  return total;
}

FragmentLists GpuFragmentLists::download() const {
  FragmentLists f;
  f.width = width_;
  f.height = height_;
  f.offsets = offsets_.download_vector<uint32_t>(texel_count(width_, height_) + 1);
  f.fragments.resize(total_);
  static_assert(sizeof(Fragment) == kFragmentBytes);
  if (total_) fragments_.download(f.fragments.data(), total_ * kFragmentBytes);
  return f;
}

namespace {

// Points `view_record` (allocated on first use) at `view`: the kernels' RasterView.
void upload_view(Device& device, Buffer& view_record, const LightView& view) {
  if (view_record.empty()) view_record = Buffer(device, sizeof(shader::RasterView), "a map's view");
  const shader::RasterView record = view.shared();
  view_record.upload(&record, sizeof(record));
}

float z_min_of(const GpuRasterState& s) {
  return s.z_min_bits == kRasterEmptyWord ? kInfinity : shader::raster_order_float(s.z_min_bits);
}

}  // namespace

void GpuRasterizer::layered_depth_map(CommandList& cl, const Submit& submit, std::string_view stage,
                                      const GpuScene& scene, const LightView& view, const LayerOptions& options,
                                      GpuLayeredDepthMap* out, uint64_t object_flags) {
  if (options.layers < 1 || options.layers > 255)
    throw Error("GPU rasterizer: layers = {} must be in [1, 255]", options.layers);
  if (!(options.distinct_epsilon >= 0)) throw Error("GPU rasterizer: distinct_epsilon must be >= 0");
  // The host writes the view record and may reallocate buffers below: nothing recorded before
  // may still be waiting to read them.
  submit();
  const int k = options.layers;
  out->resize(*device_, view.width(), view.height(), k);
  out->view_ = view;
  upload_view(*device_, out->view_record_, view);
  const uint64_t texels = texel_count(view.width(), view.height());
  const GpuRasterState s = render_passes(
      cl, submit, stage, scene, view, out->view_record_.address(), options.filter, object_flags,
      [&](const shader::RasterFillParams& fp) {
        cl.fill(out->counts_, 0);
        cl.fill(out->front_, kMinusInfinityBits);  // every fragment lies behind "no layer yet"
        shader::RasterPeelParams pp{};
        pp.scene = scene.address();
        pp.view = out->view_record_.address();
        pp.state = state_.address();
        pp.triangles = fp.triangles;
        pp.items = fp.items;
        pp.keys = out->keys_.address();
        pp.front = out->front_.address();
        pp.samples = out->samples_.address();
        pp.item_capacity = fp.item_capacity;
        pp.k = static_cast<uint32_t>(k);
        pp.epsilon = options.distinct_epsilon;
        shader::RasterLayerResolveParams rp{};
        rp.scene = scene.address();
        rp.view = out->view_record_.address();
        rp.state = state_.address();
        rp.keys = out->keys_.address();
        rp.front = out->front_.address();
        rp.samples = out->samples_.address();
        rp.counts = out->counts_.address();
        rp.k = static_cast<uint32_t>(k);
        // k peels, then one pass that only joins coincident fragments into the last layer.
        for (int layer = 0; layer <= k; ++layer) {
          pp.layer = static_cast<uint32_t>(layer);
          if (layer < k) cl.fill(out->keys_, kRasterEmptyWord);
          cl.dispatch_indirect("raster_layer_peel", state_, offsetof(GpuRasterState, fill_groups_x), pp);
          if (layer == k) break;
          rp.layer = static_cast<uint32_t>(layer);
          cl.dispatch("raster_layer_resolve", texels, rp);
        }
      });
  out->z_min_ = z_min_of(s);
}

void GpuRasterizer::fragment_lists(CommandList& cl, const Submit& submit, std::string_view stage,
                                   const GpuScene& scene, const LightView& view, const RasterFilter& filter,
                                   GpuFragmentLists* out, uint64_t object_flags) {
  submit();
  out->resize(*device_, view.width(), view.height());
  out->view_ = view;
  upload_view(*device_, out->view_record_, view);
  const uint64_t texels = texel_count(view.width(), view.height());
  if (texels >= 0xffffffffull)
    throw Error("GPU rasterizer: a {}x{} map has too many texels for fragment lists", view.width(), view.height());
  // At first room for two fragments a texel (or what the last render needed), unless a test asks
  // for less.
  out->reserve(*device_, fragment_capacity_for_testing_ ? fragment_capacity_for_testing_
                                                        : std::max<uint64_t>(out->capacity_, 2 * texels));
  fragment_capacity_for_testing_ = 0;
  int attempts = 0;
  for (;;) {
    const GpuRasterState s = render_passes(
        cl, submit, stage, scene, view, out->view_record_.address(), filter, object_flags,
        [&](const shader::RasterFillParams& fp) {
          cl.fill(out->counts_, 0);
          shader::RasterFragmentParams p{};
          p.scene = scene.address();
          p.view = out->view_record_.address();
          p.state = state_.address();
          p.triangles = fp.triangles;
          p.items = fp.items;
          p.counts = out->counts_.address();
          p.offsets = out->offsets_.address();
          p.fragments = out->fragments_.address();
          p.item_capacity = fp.item_capacity;
          p.fragment_capacity = out->capacity_;
          cl.dispatch_indirect("raster_fragment_count", state_, offsetof(GpuRasterState, fill_groups_x), p);
          out->scan_.exclusive(cl, out->counts_.address(), out->offsets_.address(), static_cast<uint32_t>(texels));
          cl.fill(out->counts_, 0);  // the scatter's cursors
          cl.dispatch_indirect("raster_fragment_scatter", state_, offsetof(GpuRasterState, fill_groups_x), p);
          shader::RasterFragmentSortParams sp{};
          sp.offsets = out->offsets_.address();
          sp.fragments = out->fragments_.address();
          sp.texels = static_cast<uint32_t>(texels);
          sp.fragment_capacity = out->capacity_;
          cl.dispatch("raster_fragment_sort", texels, sp);
        });
    attempts += attempts_;
    attempts_ = attempts;  // every render of this call, the fragments' retries too
    if (s.fragments > 0xffffffffull)
      throw Error("GPU rasterizer: {} fragments are more than one map's lists can index (at most {})", s.fragments,
                  0xffffffffull);
    uint32_t total = 0;
    out->offsets_.download(&total, sizeof(total), texels * sizeof(uint32_t));
    out->total_ = total;
    if (total <= out->capacity_) return;
    // The lists outgrew the buffer: room for all of them (the count is exact), and again.
    out->reserve(*device_, total);
  }
}

}  // namespace penumbra::gpu
