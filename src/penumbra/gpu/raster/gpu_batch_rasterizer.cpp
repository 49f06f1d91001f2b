#include "penumbra/gpu/raster/gpu_batch_rasterizer.h"

#include <algorithm>
#include <cstddef>

#include "penumbra/core/error.h"
#include "penumbra/gpu/raster/raster_batch_layout_shared.h"

namespace penumbra::gpu {
namespace {

using shader::GpuRasterBatchTriangle;
using shader::GpuRasterBatchView;
using shader::GpuRasterItem;
using shader::GpuRasterState;

constexpr uint32_t kBatchEmptyWord = 0xffffffffu;    // an empty key (both words)
constexpr uint64_t kBatchMaxCapacity = 0xffffffffu;  // items and triangles are indexed by uint32

// The first capacities for a batch (scratch_bytes counts these): set-up triangles for every
// (triangle, view) and an eighth more (fans of clipped ones); work items for two tiles a triangle
// and view, two per tile of the maps, and each view's partial tiles.
uint64_t batch_first_triangles(uint64_t triangles, uint64_t views) { return (triangles + triangles / 8 + 64) * views; }
uint64_t batch_first_items(uint64_t triangles, uint64_t views, uint64_t texels) {
  return 2 * triangles * views + texels / 128 + 64 * views + 1024;
}

uint64_t g_budget_for_testing = 0;
uint32_t g_first_triangles_for_testing = 0, g_first_items_for_testing = 0;

}  // namespace

DepthMap GpuDepthMapBatch::download(int i) const {
  const LightView& v = views_[i];
  const uint64_t n = static_cast<uint64_t>(v.width()) * v.height();
  std::vector<uint64_t> keys = keys_.download_vector<uint64_t>(n, first_[i] * 8);
  DepthMap m;
  m.resize(v.width(), v.height());
  for (uint64_t t = 0; t < n; ++t) {
    if (keys[t] == ~uint64_t{0}) {
      m.z[t] = kInfinity;
      m.triangle[t] = kNoTriangle;
    } else {
      m.z[t] = shader::raster_key_depth(keys[t]);
      m.triangle[t] = static_cast<uint32_t>(keys[t]);
    }
    m.depth[t] = kInfinity;
    m.opacity[t] = 0.0f;
  }
  if (resolved_) opacity_.download(m.opacity.data(), n * 4, first_[i] * 4);
  return m;
}

uint64_t GpuDepthMapBatch::device_bytes() const {
  uint64_t total = 0;
  for (const Buffer* b : {&views_buffer_, &keys_, &z_, &opacity_}) total += b->bytes();
  return total;
}

uint64_t GpuDepthMapBatch::bytes(uint64_t texels, uint64_t views, bool resolve) {
  return texels * (resolve ? 16 : 8) + views * sizeof(GpuRasterBatchView);
}

GpuBatchRasterizer::GpuBatchRasterizer(Device& device)
    : device_(&device), scratch_(sizeof(GpuRasterBatchTriangle), "the batch rasterizer") {
  state_ = Buffer(device, sizeof(GpuRasterState), "the batch rasterizer's counters");
  if (g_first_triangles_for_testing > 0 && g_first_items_for_testing > 0)
    set_capacities_for_testing(g_first_triangles_for_testing, g_first_items_for_testing);
}

uint64_t GpuBatchRasterizer::scratch_bytes(uint64_t triangles, uint64_t views, uint64_t texels) {
  return batch_first_triangles(triangles, views) * sizeof(GpuRasterBatchTriangle) +
         batch_first_items(triangles, views, texels) * sizeof(GpuRasterItem) + sizeof(GpuRasterState);
}

uint64_t GpuBatchRasterizer::scratch_device_bytes() const {
  uint64_t total = 0;
  for (const Buffer* b : {&state_, &orientation_, &outline_, &view_flags_}) total += b->bytes();
  return total + scratch_.device_bytes();
}

int GpuBatchRasterizer::batch_size(uint64_t triangles, uint64_t texels_per_view, bool resolve, int views,
                                   uint64_t budget) {
  const uint64_t per_view =
      GpuDepthMapBatch::bytes(texels_per_view, 1, resolve) + scratch_bytes(triangles, 1, texels_per_view);
  uint64_t n = std::max<uint64_t>(1, budget / std::max<uint64_t>(1, per_view));
  n = std::min<uint64_t>(n, std::max(1, views));
  // One set-up thread per (triangle, view) and one resolve thread per texel: the dispatches index
  // them with 32 bits.
  n = std::min<uint64_t>(n, std::max<uint64_t>(1, kBatchMaxCapacity / std::max<uint64_t>(1, triangles)));
  n = std::min<uint64_t>(n, std::max<uint64_t>(1, kBatchMaxCapacity / std::max<uint64_t>(1, texels_per_view)));
  return static_cast<int>(n);
}

uint64_t GpuBatchRasterizer::batch_budget() {
  return g_budget_for_testing > 0 ? g_budget_for_testing : uint64_t{256} << 20;
}

void GpuBatchRasterizer::set_batch_budget_for_testing(uint64_t bytes) { g_budget_for_testing = bytes; }

void GpuBatchRasterizer::set_first_capacities_for_testing(uint32_t triangles, uint32_t items) {
  g_first_triangles_for_testing = triangles;
  g_first_items_for_testing = items;
}

void GpuBatchRasterizer::set_capacities_for_testing(uint32_t triangles, uint32_t items) {
  scratch_.set_for_testing(*device_, triangles, items);
}

void GpuBatchRasterizer::depth_maps(CommandList& cl, const Submit& submit, std::string_view stage,
                                    const GpuScene& scene, std::span<const LightView> views,
                                    const RasterFilter& filter, bool resolve, GpuDepthMapBatch* out,
                                    const RasterOutlineCull* cull, const RasterViewCulling* view_culling) {
  if (views.empty()) throw Error("GPU rasterizer: a batch of no views");
  // The host writes the views and may reallocate buffers below: nothing recorded before may still
  // be waiting to read them.
  submit();
  const uint64_t triangles = scene.triangle_count();
  const uint64_t n_views = views.size();
  if (triangles * n_views > kBatchMaxCapacity)
    throw Error("GPU rasterizer: {} triangles x {} views is more than one batch can index", triangles, n_views);

  // The views and where their texels start.
  std::vector<GpuRasterBatchView> records(n_views);
  out->views_.assign(views.begin(), views.end());
  out->first_.resize(n_views);
  uint64_t texels = 0;
  for (uint64_t i = 0; i < n_views; ++i) {
    records[i].view = views[i].shared();
    records[i].first_texel = texels;
    out->first_[i] = texels;
    texels += static_cast<uint64_t>(views[i].width()) * static_cast<uint64_t>(views[i].height());
  }
  if (texels > kBatchMaxCapacity)
    throw Error("GPU rasterizer: a batch of {} views holds {} texels, more than one batch can index (at most {})",
                n_views, texels, kBatchMaxCapacity);
  ensure_buffer(*device_, out->views_buffer_, n_views * sizeof(GpuRasterBatchView), "a batch's views");
  out->views_buffer_.upload(records.data(), n_views * sizeof(GpuRasterBatchView));
  ensure_buffer(*device_, out->keys_, texels * 8, "a batch of depth maps' keys");
  if (resolve) {
    ensure_buffer(*device_, out->z_, texels * 4, "a batch of depth maps' depths");
    ensure_buffer(*device_, out->opacity_, texels * 4, "a batch of depth maps' opacities");
  }
  out->texels_ = texels;
  out->resolved_ = resolve;

  uint32_t outline_count = 0;
  if (cull && !cull->outline.empty()) {
    orientation_ = make_buffer<float>(*device_, cull->orientation, "the batch's object orientations");
    outline_ = make_buffer<Vec3f>(*device_, cull->outline, "the batch's culling outline");
    outline_count = static_cast<uint32_t>(cull->outline.size());
  }
  const bool view_flags = view_culling && !view_culling->flags.empty();
  if (view_flags) {
    if (view_culling->flags.size() != n_views * view_culling->objects)
      throw Error("GPU rasterizer: {} per-view culling flags for {} views of {} objects", view_culling->flags.size(),
                  n_views, view_culling->objects);
    const uint64_t bytes = view_culling->flags.size() * sizeof(uint32_t);
    ensure_buffer(*device_, view_flags_, bytes, "the batch's per-view culling flags");
    view_flags_.upload(view_culling->flags.data(), bytes);
  }
  const uint64_t want_triangles = std::min(kBatchMaxCapacity, batch_first_triangles(triangles, n_views));
  const uint64_t want_items = std::min(kBatchMaxCapacity, batch_first_items(triangles, n_views, texels));
  if (scratch_.empty()) scratch_.ensure(*device_, want_triangles, want_items);

  stats_ = {};
  stats_.triangles = triangles * n_views;
  attempts_ = 0;
  for (;;) {
    ++attempts_;
    cl.stage(stage);
    cl.fill(out->keys_, kBatchEmptyWord, 0, texels * 8);
    cl.fill(state_, 0);
    shader::RasterBatchSetupParams sp{};
    sp.scene = scene.address();
    sp.views = out->views_buffer_.address();
    sp.state = state_.address();
    sp.triangles = scratch_.triangles_address();
    sp.items = scratch_.items_address();
    sp.orientation = outline_count > 0 ? orientation_.address() : 0;
    sp.outline = outline_count > 0 ? outline_.address() : 0;
    sp.view_object_flags = view_flags ? view_flags_.address() : 0;
    sp.object_count = view_flags ? view_culling->objects : 0;
    sp.triangle_count = static_cast<uint32_t>(triangles);
    sp.view_count = static_cast<uint32_t>(n_views);
    sp.triangle_capacity = scratch_.triangle_capacity();
    sp.item_capacity = scratch_.item_capacity();
    sp.culling = raster_culling_code(filter);
    sp.opaque_only = filter.opaque_only ? 1u : 0u;
    sp.outline_count = outline_count;
    cl.dispatch("raster_batch_setup", triangles * n_views, sp);
    // The one mode's indirect arguments: it reads only the counters and the capacities.
    shader::RasterFillParams ap{};
    ap.state = state_.address();
    ap.triangle_capacity = scratch_.triangle_capacity();
    ap.item_capacity = scratch_.item_capacity();
    cl.dispatch("raster_fill_args", 1, ap);
    shader::RasterBatchFillParams fp{};
    fp.scene = scene.address();
    fp.views = out->views_buffer_.address();
    fp.state = state_.address();
    fp.triangles = scratch_.triangles_address();
    fp.items = scratch_.items_address();
    fp.keys = out->keys_.address();
    fp.item_capacity = scratch_.item_capacity();
    cl.dispatch_indirect("raster_batch_fill", state_, offsetof(GpuRasterState, fill_groups_x), fp);
    if (resolve) {
      shader::RasterBatchResolveParams rp{};
      rp.scene = scene.address();
      rp.views = out->views_buffer_.address();
      rp.keys = out->keys_.address();
      rp.z = out->z_.address();
      rp.opacity = out->opacity_.address();
      rp.texels = texels;
      rp.view_count = static_cast<uint32_t>(n_views);
      cl.dispatch("raster_batch_resolve", texels, rp);
    }
    submit();
    GpuRasterState s{};
    state_.download(&s, sizeof(s));
    if (scratch_.fitted_or_grown(*device_, s, &stats_)) {
      return;
    }
  }
}

}  // namespace penumbra::gpu
