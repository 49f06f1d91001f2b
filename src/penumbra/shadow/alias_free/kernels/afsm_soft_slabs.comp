#version 460
// afsm on the GPU: the depth slabs' bounds (the CPU's split_by_depth, texel_lists.cpp: slabs of
// equal entry counts by depth). One work group over the histogram afsm_soft_list_count made
// (kAfsmDepthBins bins, 4 a thread): a prefix sum in shared memory, then each bin's slab from the
// entries before its middle, floor(slabs × (before + count / 2) / total), which never decreases
// with depth; a bin is never cut (equal depths stay in one slab, as on the CPU). The counts are
// replaced by the slabs.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/alias_free/kernels/afsm_soft_access.glsl"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { AfsmSoftParams p; } pc;

const uint kBinsPerThread = kAfsmDepthBins / 256u;
shared uint partial[256];

void main() {
  uint t = gl_LocalInvocationID.x;
  AfsmSlabsRef slabs = afsm_slabs(pc.p.view);
  uint count[kBinsPerThread];
  uint mine = 0u;
  for (uint j = 0u; j < kBinsPerThread; ++j) {
    count[j] = slabs.s.slab_of_bin[kBinsPerThread * t + j];
    mine += count[j];
  }
  partial[t] = mine;
  barrier();
  // Hillis and Steele's inclusive scan of the threads' sums.
  for (uint offset = 1u; offset < 256u; offset *= 2u) {
    uint add = t >= offset ? partial[t - offset] : 0u;
    barrier();
    partial[t] += add;
    barrier();
  }
  uint64_t total = uint64_t(partial[255]);
  uint64_t before = uint64_t(partial[t] - mine);
  uint64_t n = uint64_t(max(pc.p.slabs, 1u));
  for (uint j = 0u; j < kBinsPerThread; ++j) {
    uint slab = total == 0ul ? 0u : uint(min((2ul * before + uint64_t(count[j])) * n / (2ul * total), n - 1ul));
    slabs.s.slab_of_bin[kBinsPerThread * t + j] = slab;
    before += uint64_t(count[j]);
  }
}
