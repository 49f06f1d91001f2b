#version 460
// gpu/scan.h exclusive_scan: an exclusive prefix sum of `count` uints in place, the total after
// them. One workgroup of 256 threads; no subgroup size assumed (shared memory only).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/scan_shared.h"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { ExclusiveScanParams p; } pc;

shared uint sums[256];

void main() {
  uint t = gl_LocalInvocationID.x;
  uint n = pc.p.count;
  uint chunk = (n + 255u) / 256u;
  uint begin = min(t * chunk, n), end = min(begin + chunk, n);
  Uints v = Uints(pc.p.values);
  uint own = 0u;
  for (uint i = begin; i < end; ++i) own += v.v[i];
  sums[t] = own;
  barrier();
  // Hillis-Steele over the 256 run sums (inclusive).
  for (uint off = 1u; off < 256u; off <<= 1u) {
    uint add = t >= off ? sums[t - off] : 0u;
    barrier();
    sums[t] += add;
    barrier();
  }
  uint run = sums[t] - own;
  for (uint i = begin; i < end; ++i) {
    uint x = v.v[i];
    v.v[i] = run;
    run += x;
  }
  if (t == 255u) v.v[n] = sums[255];
}
