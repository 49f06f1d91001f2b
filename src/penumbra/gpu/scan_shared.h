// The GPU's prefix sums (gpu/scan_gpu.h), byte by byte. Common subset of C++ and GLSL
// (core/shader_compat.h), scalar block layout.
//
// An exclusive scan of n uint values writes n + 1 results: out[i] = in[0] + ... + in[i - 1], so
// out[n] is the total (the offsets of n lists of in[i] items each, and their sum). It runs as a
// tree of blocks of kScanBlock values: scan_blocks scans each block in shared memory and writes
// its total; the totals are scanned the same way (recursively, until one block holds them);
// scan_add adds each block's scanned total to its values.
#ifndef PENUMBRA_GPU_SCAN_SHARED_H
#define PENUMBRA_GPU_SCAN_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// Values per block: scan_blocks' 256 threads take two each.
PN_CONST uint kScanBlock = 512u;

// scan_blocks.comp's push constants: src[0, n) (values past n count as 0) scanned into
// dst[0, n] block by block (src and dst may be the same buffer); each block's total into sums.
struct ScanBlocksParams {
  uint64_t src;
  uint64_t dst;
  uint64_t sums;  // uint per block (none: 0, when one block holds everything)
  uint n;
  uint pad;
};

// scan_add.comp's push constants: dst[i] += sums[i / kScanBlock] for i in [0, n].
struct ScanAddParams {
  uint64_t dst;
  uint64_t sums;
  uint n;
  uint pad;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::ScanBlocksParams) == 32);
static_assert(sizeof(penumbra::shader::ScanAddParams) == 24);
#endif

#endif  // PENUMBRA_GPU_SCAN_SHARED_H
