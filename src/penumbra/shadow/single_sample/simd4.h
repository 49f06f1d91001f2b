// Four floats in one SSE/NEON register through the GCC/Clang vector extensions, for the
// single-sample search (four triangles against one ray, or four rays against one box or
// triangle). No -march flag needed: SSE2 is the x86-64 baseline.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstring>
#if defined(__SSE2__)
#include <immintrin.h>
#endif

// The eight-lane helpers are inlined into AVX2 functions only (single_sample.cpp); as
// out-of-line functions they would pass 32-byte vectors without AVX.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"

namespace penumbra::single_sample {

#define PENUMBRA_SIMD_INLINE inline __attribute__((always_inline))

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
inline f4 sqrt4(f4 a) {
#if defined(__SSE2__)
  return (f4)_mm_sqrt_ps((__m128)a);
#else
  return f4{std::sqrt(a[0]), std::sqrt(a[1]), std::sqrt(a[2]), std::sqrt(a[3])};
#endif
}
inline bool any4(i4 m) { return (m[0] | m[1] | m[2] | m[3]) != 0; }
inline int mask4(i4 m) { return (m[0] & 1) | (m[1] & 2) | (m[2] & 4) | (m[3] & 8); }
inline float hmin4(f4 a) { return std::min(std::min(a[0], a[1]), std::min(a[2], a[3])); }

// Eight lanes for the packet search: GCC/Clang lower them to two SSE registers (two
// independent dependency chains) or one AVX register where the target has it.
typedef float f8 __attribute__((vector_size(32)));
typedef int i8 __attribute__((vector_size(32)));

// Width-generic helpers (V = f4 or f8, M the matching int vector).
template <typename V>
PENUMBRA_SIMD_INLINE V splat_v(float x) {
  return V{} + x;
}
template <typename V>
PENUMBRA_SIMD_INLINE V vmin_v(V a, V b) {
  return a < b ? a : b;
}
template <typename V>
PENUMBRA_SIMD_INLINE V vmax_v(V a, V b) {
  return a > b ? a : b;
}
template <typename V>
PENUMBRA_SIMD_INLINE V vabs_v(V a) {
  return a < 0.0f ? -a : a;
}
// Lane i of a comparison mask (0 or -1) as bit i, and the smallest lane: log2(W) shuffle
// steps, generic (no target-specific intrinsic, so they inline into code of any target).
PENUMBRA_SIMD_INLINE int mask_v(i4 m) {
  i4 v = m & i4{1, 2, 4, 8};
  v |= __builtin_shufflevector(v, v, 2, 3, 0, 1);
  v |= __builtin_shufflevector(v, v, 1, 0, 3, 2);
  return v[0];
}
PENUMBRA_SIMD_INLINE int mask_v(i8 m) {
  i8 v = m & i8{1, 2, 4, 8, 16, 32, 64, 128};
  v |= __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3);
  v |= __builtin_shufflevector(v, v, 2, 3, 0, 1, 6, 7, 4, 5);
  v |= __builtin_shufflevector(v, v, 1, 0, 3, 2, 5, 4, 7, 6);
  return v[0];
}
PENUMBRA_SIMD_INLINE float hmin_v(f4 a) {
  a = vmin_v(a, __builtin_shufflevector(a, a, 2, 3, 0, 1));
  a = vmin_v(a, __builtin_shufflevector(a, a, 1, 0, 3, 2));
  return a[0];
}
PENUMBRA_SIMD_INLINE float hmin_v(f8 a) {
  a = vmin_v(a, __builtin_shufflevector(a, a, 4, 5, 6, 7, 0, 1, 2, 3));
  a = vmin_v(a, __builtin_shufflevector(a, a, 2, 3, 0, 1, 6, 7, 4, 5));
  a = vmin_v(a, __builtin_shufflevector(a, a, 1, 0, 3, 2, 5, 4, 7, 6));
  return a[0];
}

}  // namespace penumbra::single_sample

#pragma GCC diagnostic pop
