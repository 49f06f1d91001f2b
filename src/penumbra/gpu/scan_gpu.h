// Exclusive prefix sums of uint values on the device (layout and kernels: gpu/scan_shared.h):
// the offsets of per-item lists from their counts (the fragment lists of gpu/raster/, sintorn2008
// and xie2007 §5's count, scan, fill). Shared machinery: methods record it, they do not write
// their own scans.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/commands.h"

namespace penumbra::gpu {

class GpuScan {
 public:
  // Records out[i] = in[0] + ... + in[i - 1] for i in [0, n]: out holds n + 1 uints (out[n] is
  // the total; in and out may be one buffer, then in needs room for n + 1). Scratch for the
  // block totals is allocated on the first call and kept, grown where a later n needs more:
  // growing frees what commands recorded before may still use, so scans of different arrays in
  // one command list take one GpuScan each (or the largest first).
  void exclusive(CommandList& commands, uint64_t in, uint64_t out, uint32_t n);
  // The scratch exclusive() holds for n values (memory estimates).
  static uint64_t scratch_bytes(uint64_t n);
  uint64_t device_bytes() const;

 private:
  std::vector<Buffer> sums_;  // per level of the tree: one uint per block of the level below, plus its total
  std::vector<uint32_t> sizes_;
};

}  // namespace penumbra::gpu
