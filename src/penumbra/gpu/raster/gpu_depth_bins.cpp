// GpuRasterizer::depth_bin_masks and the device's depth-bin masks (gpu_depth_bins.h).
#include "penumbra/gpu/raster/gpu_depth_bins.h"

#include <cmath>
#include <cstddef>

#include "penumbra/core/error.h"
#include "penumbra/gpu/raster/gpu_rasterizer.h"
#include "penumbra/gpu/raster/raster_bins_layout_shared.h"

namespace penumbra::gpu {

void GpuDepthBinMasks::resize(Device& device, int w, int h, int nearest_bins) {
  if (w != width_ || h != height_ || masks_.empty()) {
    masks_ = Buffer();
    masks_ = Buffer(device, static_cast<uint64_t>(w) * static_cast<uint64_t>(h) * 4, "depth-bin masks");
    nearest_ = Buffer();
  }
  const uint64_t nearest_bytes = DepthBinMasks::nearest_bytes(w, h, nearest_bins);
  if (nearest_.bytes() != nearest_bytes) {
    nearest_ = Buffer();  // freed before the next is made
    if (nearest_bytes > 0) nearest_ = Buffer(device, nearest_bytes, "depth bins' nearest depths");
  }
  if (view_record_.empty()) view_record_ = Buffer(device, sizeof(shader::RasterView), "depth-bin masks' view");
  width_ = w;
  height_ = h;
  nearest_bins_ = nearest_bins;
}

uint64_t GpuDepthBinMasks::bytes(int w, int h, int nearest_bins) {
  return static_cast<uint64_t>(w) * static_cast<uint64_t>(h) * 4 + DepthBinMasks::nearest_bytes(w, h, nearest_bins) +
         sizeof(shader::RasterView);
}

DepthBinMasks GpuDepthBinMasks::download() const {
  DepthBinMasks m;
  m.width = width_;
  m.height = height_;
  m.masks = masks_.download_vector<uint32_t>(static_cast<size_t>(width_) * height_);
  if (nearest_bins_ > 0) {
    // The device's +infinity where a bin is empty is the CPU's 0.
    const std::vector<float> n = nearest_.download_vector<float>(static_cast<size_t>(width_) * height_ * nearest_bins_);
    m.nearest.resize(n.size());
    for (size_t i = 0; i < n.size(); ++i) m.nearest[i] = std::isinf(n[i]) ? 0.0f : n[i];
  }
  return m;
}

void GpuRasterizer::depth_bin_masks(CommandList& cl, const Submit& submit, std::string_view stage,
                                    const GpuScene& scene, const LightView& view, const RasterFilter& filter,
                                    const DepthBins& bins, uint64_t object_flags, GpuDepthBinMasks* out) {
  // Rasterizer::depth_bin_masks's checks.
  if (bins.count < 1 || bins.count > 32) throw Error("GPU rasterizer: {} depth bins must be in [1, 32]", bins.count);
  if (!(bins.width > 0) || !std::isfinite(bins.first))
    throw Error("GPU rasterizer: depth bins need a finite start and a positive width");
  const TileDepthBins tile_bins = tile_depth_bins(bins, view.width(), view.height(), "GPU rasterizer");
  // The host writes the view record and may reallocate buffers below.
  submit();
  if (!tile_bins.records.empty()) {
    ensure_buffer(*device_, tile_bins_, tile_bins.records.size() * sizeof(shader::RasterDepthBins),
                       "the depth bins per tile");
    tile_bins_.upload(std::span<const shader::RasterDepthBins>(tile_bins.records));
  }
  out->resize(*device_, view.width(), view.height(), bins.nearest ? bins.count : 0);
  out->view_ = view;
  const shader::RasterView record = view.shared();
  out->view_record_.upload(&record, sizeof(record));
  render_passes(cl, submit, stage, scene, view, out->view_record_.address(), filter, object_flags,
                [&](const shader::RasterFillParams& fp) {
                  cl.fill(out->masks_, 0);
                  if (bins.nearest) cl.fill(out->nearest_, 0x7f800000u);  // +infinity
                  shader::RasterBinsFillParams bp{};
                  bp.fill = fp;
                  bp.fill.keys = out->masks_.address();
                  bp.bins = shader::raster_depth_bins(bins.first, bins.width, bins.count);
                  if (!tile_bins.records.empty()) {
                    bp.tile_bins = tile_bins_.address();
                    bp.tile_shift = tile_bins.shift;
                    bp.tile_columns = tile_bins.columns;
                    bp.width = view.width();
                  }
                  if (bins.nearest) {
                    bp.nearest = out->nearest_.address();
                    bp.plane = static_cast<uint32_t>(view.width() * view.height());
                  }
                  cl.dispatch_indirect("raster_fill_bins", state_, offsetof(shader::GpuRasterState, fill_groups_x), bp);
                });
}

}  // namespace penumbra::gpu
