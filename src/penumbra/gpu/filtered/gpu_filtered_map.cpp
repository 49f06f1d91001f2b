#include "penumbra/gpu/filtered/gpu_filtered_map.h"

#include <algorithm>
#include <bit>

#include "penumbra/core/error.h"
#include "penumbra/gpu/filtered/filtered_layout_shared.h"

namespace penumbra::gpu {
namespace {

uint64_t sat_entry_bytes(GpuSummedAreaTable::Entries e) { return e == GpuSummedAreaTable::Entries::Double ? 8 : 4; }

// `buffer` holding at least `bytes` (a new one, what recorded commands still read submitted
// first, when it is smaller).
void ensure_filtered_bytes(Buffer& buffer, Device& device, const SubmitRecorded& submit, uint64_t bytes, const char* what) {
  if (!buffer.empty() && buffer.bytes() >= bytes) return;
  if (!buffer.empty()) submit();
  buffer = Buffer();
  buffer = Buffer(device, std::max<uint64_t>(16, bytes), what);
}

}  // namespace

uint64_t GpuSummedAreaTable::bytes(int width, int height, int channels, Entries entries) {
  return (static_cast<uint64_t>(width) + 1) * (static_cast<uint64_t>(height) + 1) * static_cast<uint64_t>(channels) *
         sat_entry_bytes(entries);
}

void GpuSummedAreaTable::build_from_floats(Device& device, CommandList& commands, const SubmitRecorded& submit,
                                           uint64_t source, int width, int height, int channels) {
  if (channels < 1 || channels > shader::kFilteredMaxChannels)
    throw Error("GPU summed-area table: {} channels (1 to 4)", channels);
  const uint32_t C = static_cast<uint32_t>(channels);
  layout_ = {width, height, channels, C, (static_cast<uint32_t>(width) + 1) * C, 1u};
  build(device, commands, submit, source, shader::kSatSourceFloats, Entries::Double);
}

void GpuSummedAreaTable::build_from_bits(Device& device, CommandList& commands, const SubmitRecorded& submit,
                                         uint64_t masks, int width, int height, int planes, Entries entries) {
  if (planes < 1 || planes > 32) throw Error("GPU summed-area table: {} bit planes (1 to 32)", planes);
  const uint32_t stride = static_cast<uint32_t>(width) + 1;
  layout_ = {width, height, planes, 1u, stride, stride * (static_cast<uint32_t>(height) + 1)};
  build(device, commands, submit, masks, shader::kSatSourceBits, entries);
}

void GpuSummedAreaTable::build(Device& device, CommandList& commands, const SubmitRecorded& submit, uint64_t source,
                               uint32_t source_kind, Entries entries) {
  const uint64_t total = bytes(layout_.width, layout_.height, layout_.channels, entries);
  if (total / sat_entry_bytes(entries) > 0xffffffffu)
    throw Error("GPU summed-area table: {} x {} x {} entries are more than 32-bit indices reach", layout_.width + 1,
                layout_.height + 1, layout_.channels);
  ensure_filtered_bytes(table_, device, submit, total, "a summed-area table");
  shader::SatBuildParams p{};
  p.source = source;
  p.table = table_.address();
  p.table_layout = layout_;
  p.source_kind = source_kind;
  p.entry_kind = entries == Entries::Double ? shader::kSatEntriesDouble : shader::kSatEntriesUint;
  commands.dispatch("sat_scan_rows", static_cast<uint64_t>(layout_.height) * layout_.channels, p);
  commands.dispatch("sat_scan_columns", (static_cast<uint64_t>(layout_.width) + 1) * layout_.channels, p);
}

uint64_t GpuMipChain::bytes(int width, int height, int channels) {
  const int side = static_cast<int>(std::bit_ceil(static_cast<unsigned>(std::max({width, height, 1}))));
  return static_cast<uint64_t>(shader::mip_level_offset(side, channels, std::bit_width(static_cast<unsigned>(side)))) *
         sizeof(float);
}

void GpuMipChain::build(Device& device, CommandList& commands, const SubmitRecorded& submit, uint64_t source,
                        int width, int height, int channels, std::span<const float> outside) {
  if (channels < 1 || channels > shader::kFilteredMaxChannels || outside.size() != static_cast<size_t>(channels))
    throw Error("GPU mip chain: 1 to 4 channels, with as many outside values");
  const int side = static_cast<int>(std::bit_ceil(static_cast<unsigned>(std::max({width, height, 1}))));
  view_ = {};
  view_.side = side;
  view_.levels = std::bit_width(static_cast<unsigned>(side));
  view_.channels = channels;
  std::copy(outside.begin(), outside.end(), view_.outside);
  ensure_filtered_bytes(texels_, device, submit, bytes(width, height, channels), "a mip chain");
  shader::MipLevel0Params p0{};
  p0.source = source;
  p0.texels = texels_.address();
  p0.width = width;
  p0.height = height;
  p0.side = side;
  p0.channels = channels;
  std::copy(outside.begin(), outside.end(), p0.outside);
  commands.dispatch("mip_level0", static_cast<uint64_t>(side) * side * channels, p0);
  for (int l = 1; l < view_.levels; ++l) {
    shader::MipReduceParams p{};
    p.texels = texels_.address();
    p.fine_offset = shader::mip_level_offset(side, channels, l - 1);
    p.coarse_offset = shader::mip_level_offset(side, channels, l);
    p.side = side >> l;
    p.channels = channels;
    commands.dispatch("mip_reduce", static_cast<uint64_t>(p.side) * p.side * channels, p);
  }
}

}  // namespace penumbra::gpu
