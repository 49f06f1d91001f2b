#version 460
// Test kernel (gpu/shared_functions_test.cpp): the generator of core/rng_shared.h on the GPU,
// one stream per thread, to compare bit for bit with the CPU's.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/core/rng_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push {
  Uint64s keys;     // per stream: (seed, a, b, c)
  Uint64s out_u64;  // per stream: `draws` numbers
  Floats out_float; // per stream: `draws` floats of a second stream with the same key
  uint streams;
  uint draws;
} pc;

void main() {
  uint i = pn_thread_index();
  if (i >= pc.streams) return;
  RngState r = rng_keyed(pc.keys.v[4 * i], pc.keys.v[4 * i + 1], pc.keys.v[4 * i + 2], pc.keys.v[4 * i + 3]);
  RngState f = r;
  for (uint k = 0; k < pc.draws; ++k) {
    pc.out_u64.v[i * pc.draws + k] = rng_next_u64(r);
    pc.out_float.v[i * pc.draws + k] = rng_next_float(f);
  }
}
