#version 460
// Test kernel (gpu/filtered/gpu_filtered_map_test.cpp): core/shader_compat_math.h's exp and log
// in double on the GPU (Cephes'), to compare with libm's.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/core/shader_compat_math.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push {
  uint64_t in_values;  // double per value
  uint64_t out_exp;    // double per value: pn_exp_d(x)
  uint64_t out_log;    // double per value: pn_log_d(|x| + 1e-300)
  uint count;
} pc;

void main() {
  uint i = pn_thread_index();
  if (i >= pc.count) return;
  double x = Doubles(pc.in_values).v[i];
  Doubles(pc.out_exp).v[i] = pn_exp_d(x);
  Doubles(pc.out_log).v[i] = pn_log_d(abs(x) + 1e-300lf);
}
