// Prefiltered maps on the GPU (raster/filtered_map.h's, shared machinery): summed-area tables
// of float channels or of bit planes, and float mip chains, built on the device from a map that
// is already there, in the layouts of raster/filtered_map_shared.h, so a kernel looks them up
// with the CPU's functions (sat_box_mean, sat_box_integral_*, mip_box_mean). The tables hold the
// CPU's numbers bit for bit: the same additions in the same order (gpu/filtered/kernels/).
// Users: the filtered-moment shadow maps (vsm, evsm, msm) and occlusion textures.
#pragma once

#include <cstdint>
#include <functional>
#include <span>

#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/commands.h"
#include "penumbra/raster/filtered_map_shared.h"

namespace penumbra::gpu {

// Submits what a command list recorded and waits (GpuFrame::flush in a method): called before a
// buffer that recorded commands may still read is replaced.
using SubmitRecorded = std::function<void()>;

class GpuSummedAreaTable {
 public:
  enum class Entries { Double, Uint32 };

  // The table of a width x height map of `channels` (1-4) interleaved floats at device address
  // `source` (SummedAreaTable's layout: doubles, channels interleaved), recorded into `commands`.
  void build_from_floats(Device& device, CommandList& commands, const SubmitRecorded& submit, uint64_t source,
                         int width, int height, int channels);
  // The tables of `planes` (1-32) binary planes of a width x height image of uint masks at
  // `masks` (plane k: bit k), one table per plane after another (occlusion::SatFilter's layout):
  // exact counts in uint32 (wrapping, as the CPU's) or doubles.
  void build_from_bits(Device& device, CommandList& commands, const SubmitRecorded& submit, uint64_t masks, int width,
                       int height, int planes, Entries entries);

  uint64_t address() const { return table_.address(); }
  const shader::SatTableLayout& layout() const { return layout_; }
  const Buffer& buffer() const { return table_; }  // (tests and tools read it back)
  uint64_t device_bytes() const { return table_.bytes(); }
  // What a table of these sizes holds.
  static uint64_t bytes(int width, int height, int channels, Entries entries);

 private:
  void build(Device& device, CommandList& commands, const SubmitRecorded& submit, uint64_t source, uint32_t source_kind,
             Entries entries);
  shader::SatTableLayout layout_{};
  Buffer table_;
};

class GpuMipChain {
 public:
  // The chain of a width x height map of `channels` (1-4) interleaved floats at `source`, padded
  // to a power-of-two square with `outside` (MipChain::build), recorded into `commands`.
  void build(Device& device, CommandList& commands, const SubmitRecorded& submit, uint64_t source, int width,
             int height, int channels, std::span<const float> outside);

  uint64_t address() const { return texels_.address(); }
  const shader::MipChainView& view() const { return view_; }
  const Buffer& buffer() const { return texels_; }  // (tests and tools read it back)
  uint64_t device_bytes() const { return texels_.bytes(); }
  // What a chain of a width x height map holds (MipChain::bytes).
  static uint64_t bytes(int width, int height, int channels);

 private:
  shader::MipChainView view_{};
  Buffer texels_;
};

}  // namespace penumbra::gpu
