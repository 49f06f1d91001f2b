// GpuRasterizer::depth_bin_masks and the device's depth-bin masks (gpu_depth_bins.h).
#include "penumbra/gpu/raster/gpu_depth_bins.h"

#include <cmath>
#include <cstddef>

#include "penumbra/core/error.h"
#include "penumbra/gpu/raster/gpu_rasterizer.h"
#include "penumbra/gpu/raster/raster_bins_layout_shared.h"

namespace penumbra::gpu {

void GpuDepthBinMasks::resize(Device& device, int w, int h) {
  if (w == width_ && h == height_ && !masks_.empty()) return;
  masks_ = Buffer();
  masks_ = Buffer(device, static_cast<uint64_t>(w) * static_cast<uint64_t>(h) * 4, "depth-bin masks");
  if (view_record_.empty()) view_record_ = Buffer(device, sizeof(shader::RasterView), "depth-bin masks' view");
  width_ = w;
  height_ = h;
}

uint64_t GpuDepthBinMasks::bytes(int w, int h) {
  return static_cast<uint64_t>(w) * static_cast<uint64_t>(h) * 4 + sizeof(shader::RasterView);
}

DepthBinMasks GpuDepthBinMasks::download() const {
  DepthBinMasks m;
  m.width = width_;
  m.height = height_;
  m.masks = masks_.download_vector<uint32_t>(static_cast<size_t>(width_) * height_);
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
  out->resize(*device_, view.width(), view.height());
  out->view_ = view;
  const shader::RasterView record = view.shared();
  out->view_record_.upload(&record, sizeof(record));
  render_passes(cl, submit, stage, scene, view, out->view_record_.address(), filter, object_flags,
                [&](const shader::RasterFillParams& fp) {
                  cl.fill(out->masks_, 0);
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
                  cl.dispatch_indirect("raster_fill_bins", state_, offsetof(shader::GpuRasterState, fill_groups_x), bp);
                });
}

}  // namespace penumbra::gpu
