#version 460
// The last step of a level of the GPU's exclusive prefix sum (gpu/scan_shared.h): each value
// gets its block's scanned total added (the blocks before it).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/scan_shared.h"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { ScanAddParams p; } pc;

void main() {
  uint i = pn_thread_index();
  if (i > pc.p.n) return;
  Uints(pc.p.dst).v[i] += Uints(pc.p.sums).v[i / kScanBlock];
}
