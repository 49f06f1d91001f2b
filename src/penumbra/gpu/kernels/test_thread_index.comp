#version 460
// Test kernel (device_test.cpp): each thread of a 1D dispatch adds 1 at its pn_thread_index(),
// so a grid CommandList::dispatch folded into 2D shows every index exactly once.
#include "penumbra/gpu/kernel_common.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push {
  uint64_t counts;
  uint n;
} pc;

void main() {
  uint i = pn_thread_index();
  if (i < pc.n) atomicAdd(Uints(pc.counts).v[i], 1u);
}
