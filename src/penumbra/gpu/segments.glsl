// Work items numbered across segments: segment g owns items [offsets[g], offsets[g + 1]) of an
// exclusive scan of per-segment counts (gpu/scan_gpu.h). One thread per item finds its segment.
#ifndef PENUMBRA_GPU_SEGMENTS_GLSL
#define PENUMBRA_GPU_SEGMENTS_GLSL

#include "penumbra/gpu/kernel_common.glsl"

// The segment holding item i of `count` segments: upper_bound over offsets[1 .. count], minus
// one (segments with no items are skipped).
uint segment_of(Uints offsets, uint count, uint i) {
  uint lo = 0u, n = count;
  while (n > 0u) {
    uint step = n / 2u;
    uint it = lo + step;
    if (offsets.v[it + 1u] <= i) {
      lo = it + 1u;
      n -= step + 1u;
    } else {
      n = step;
    }
  }
  return lo;
}

#endif
