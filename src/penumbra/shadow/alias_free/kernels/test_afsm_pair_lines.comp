#version 460
// Test kernel (alias_free_gpu_test.cpp): alias_free_shared.h afsm_pair_lines on the device, one
// thread per (point, triangle) record: 52 bytes in (p, v0, v1, v2, closed), 52 out (the four
// lines, then kept as a float: 1 or 0).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/alias_free/alias_free_shared.h"

layout(local_size_x = 64) in;
struct PairIn {
  vec3 p;
  vec3 v0;
  vec3 v1;
  vec3 v2;
  uint closed;
};
struct PairOut {
  AfsmPairLines lines;
  float kept;
};
layout(buffer_reference, scalar) readonly buffer PairsIn { PairIn v[]; };
layout(buffer_reference, scalar) writeonly buffer PairsOut { PairOut v[]; };
layout(push_constant, scalar) uniform Push {
  uint64_t in_pairs;
  uint64_t out_pairs;
  vec3 c;
  uint count;
  vec3 ls;
  uint pad0;
  vec3 lt;
  uint pad1;
} pc;

void main() {
  uint i = pn_thread_index();
  if (i >= pc.count) return;
  PairIn r = PairsIn(pc.in_pairs).v[i];
  vec3 normal = cross(r.v1 - r.v0, r.v2 - r.v0);
  float len = sqrt(dot(normal, normal));
  PairOut o;
  o.lines = AfsmPairLines(vec2(0.0f), 0.0f, vec2(0.0f), 0.0f, vec2(0.0f), 0.0f, vec2(0.0f), 0.0f);
  bool kept = afsm_pair_lines(r.p, r.v0, r.v1, r.v2, normal, kAfsmFlat * kAfsmFlat * len * len, r.closed != 0u, pc.c,
                              pc.ls, pc.lt, o.lines);
  o.kept = kept ? 1.0f : 0.0f;
  PairsOut(pc.out_pairs).v[i] = o;
}
