#version 460
// One level of the GPU's exclusive prefix sum (gpu/scan_shared.h): each workgroup scans one
// block of kScanBlock values in shared memory (Blelloch's up-sweep and down-sweep: no subgroup
// size assumed), writes the block's exclusive sums, and its total into sums[block]. Block values
// past n are 0, so out[n] is the total of the last block's values before it.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/scan_shared.h"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { ScanBlocksParams p; } pc;

shared uint s_values[kScanBlock];

void main() {
  uint block = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
  uint base = block * kScanBlock;
  if (base > pc.p.n) return;  // a whole group past the last block (a folded 2D grid's tail)
  uint t = gl_LocalInvocationID.x;
  Uints in_values = Uints(pc.p.src);
  for (uint k = 0u; k < 2u; ++k) {
    uint i = base + t + k * 256u;
    s_values[t + k * 256u] = i < pc.p.n ? in_values.v[i] : 0u;
  }
  // Up-sweep: partial sums in place.
  uint offset = 1u;
  for (uint d = kScanBlock >> 1; d > 0u; d >>= 1) {
    barrier();
    if (t < d) {
      uint a = offset * (2u * t + 1u) - 1u;
      uint b = offset * (2u * t + 2u) - 1u;
      s_values[b] += s_values[a];
    }
    offset <<= 1;
  }
  barrier();
  uint total = s_values[kScanBlock - 1u];
  if (t == 0u) s_values[kScanBlock - 1u] = 0u;
  // Down-sweep: the exclusive sums.
  for (uint d = 1u; d < kScanBlock; d <<= 1) {
    offset >>= 1;
    barrier();
    if (t < d) {
      uint a = offset * (2u * t + 1u) - 1u;
      uint b = offset * (2u * t + 2u) - 1u;
      uint x = s_values[a];
      s_values[a] = s_values[b];
      s_values[b] += x;
    }
  }
  barrier();
  Uints out_values = Uints(pc.p.dst);
  for (uint k = 0u; k < 2u; ++k) {
    uint i = base + t + k * 256u;
    if (i <= pc.p.n) out_values.v[i] = s_values[t + k * 256u];
  }
  if (t == 0u && pc.p.sums != 0UL) Uints(pc.p.sums).v[block] = total;
}
