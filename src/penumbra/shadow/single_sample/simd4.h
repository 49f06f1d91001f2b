// Four floats in one SSE/NEON register through the GCC/Clang vector extensions, for the
// single-sample search (four triangles against one ray, or four rays against one box or
// triangle). No -march flag needed: SSE2 is the x86-64 baseline.
#pragma once

#include <algorithm>
#include <cstring>

namespace penumbra::single_sample {

typedef float f4 __attribute__((vector_size(16)));
typedef int i4 __attribute__((vector_size(16)));

inline f4 splat(float x) { return f4{x, x, x, x}; }
inline f4 vmin4(f4 a, f4 b) { return a < b ? a : b; }
inline f4 vmax4(f4 a, f4 b) { return a > b ? a : b; }
inline f4 vabs4(f4 a) { return a < splat(0.0f) ? -a : a; }
inline f4 load4(const float* p) {
  f4 r;
  std::memcpy(&r, p, sizeof r);
  return r;
}
inline bool any4(i4 m) { return (m[0] | m[1] | m[2] | m[3]) != 0; }
inline int mask4(i4 m) { return (m[0] & 1) | (m[1] & 2) | (m[2] & 4) | (m[3] & 8); }
inline float hmin4(f4 a) { return std::min(std::min(a[0], a[1]), std::min(a[2], a[3])); }

}  // namespace penumbra::single_sample
