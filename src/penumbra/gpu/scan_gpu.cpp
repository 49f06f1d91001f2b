#include "penumbra/gpu/scan_gpu.h"

#include "penumbra/gpu/scan_shared.h"

namespace penumbra::gpu {
namespace {

// Blocks of a scan of n values (covering the n + 1 results).
uint64_t blocks(uint64_t n) { return n / shader::kScanBlock + 1; }

}  // namespace

uint64_t GpuScan::scratch_bytes(uint64_t n) {
  uint64_t bytes = 0;
  for (uint64_t b = blocks(n); b > 1; b = blocks(b)) bytes += (b + 1) * sizeof(uint32_t);
  return bytes;
}

uint64_t GpuScan::device_bytes() const {
  uint64_t bytes = 0;
  for (const Buffer& b : sums_) bytes += b.bytes();
  return bytes;
}

void GpuScan::exclusive(CommandList& commands, uint64_t in, uint64_t out, uint32_t n) {
  // The tree's levels: level l holds the block totals of level l - 1 (level 0: the values).
  std::vector<uint32_t> sizes;
  for (uint64_t b = blocks(n); b > 1; b = blocks(b)) sizes.push_back(static_cast<uint32_t>(b));
  // Grown only (a smaller scan reuses the levels): commands recorded earlier may still use them.
  bool fits = sums_.size() >= sizes.size();
  for (size_t l = 0; fits && l < sizes.size(); ++l) fits = sizes_[l] >= sizes[l];
  if (!fits) {
    sums_.clear();
    for (uint32_t s : sizes) sums_.emplace_back(commands.device(), (uint64_t(s) + 1) * sizeof(uint32_t), "a prefix sum's block totals");
    sizes_ = sizes;
  }
  // Down the tree: each level's blocks scanned, their totals into the next level's values.
  uint64_t level_in = in, level_out = out;
  uint32_t level_n = n;
  for (size_t l = 0; l <= sizes.size(); ++l) {
    shader::ScanBlocksParams p{};
    p.src = level_in;
    p.dst = level_out;
    p.sums = l < sizes.size() ? sums_[l].address() : 0;
    p.n = level_n;
    commands.dispatch("scan_blocks", blocks(level_n) * 256, p);
    if (l == sizes.size()) break;
    level_in = level_out = sums_[l].address();
    level_n = sizes[l];
  }
  // Back up: each level's values get their block's scanned total.
  for (size_t l = sizes.size(); l-- > 0;) {
    shader::ScanAddParams p{};
    p.dst = l == 0 ? out : sums_[l - 1].address();
    p.sums = sums_[l].address();
    p.n = l == 0 ? n : sizes[l - 1];
    commands.dispatch("scan_add", uint64_t(p.n) + 1, p);
  }
}

}  // namespace penumbra::gpu
