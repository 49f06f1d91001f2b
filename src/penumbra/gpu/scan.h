// Prefix sums on the device: the counts-then-offsets step of every list built on the GPU (a count
// per texel or per item, an exclusive scan, a scatter; sintorn2008 §3.1's lists).
#pragma once

#include <cstdint>

#include "penumbra/gpu/commands.h"

namespace penumbra::gpu {

// Records an exclusive prefix sum, in place, of the `count` uints at device address `values`,
// and writes their total to values[count] (the buffer holds count + 1 uints). One workgroup
// (kernels/scan_exclusive_one_group.comp): each of its 256 threads sums a run of count / 256
// values, the group scans the 256 sums in shared memory, each thread writes its run. O(count)
// work at a fraction of the device's width: meant for the per-texel and per-triangle counts
// (up to a few million), not for very long arrays. Totals must fit in 32 bits.
void exclusive_scan(CommandList& commands, uint64_t values, uint32_t count);

}  // namespace penumbra::gpu
