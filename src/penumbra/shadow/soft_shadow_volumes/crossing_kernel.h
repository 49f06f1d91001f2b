// The per-light-sample loop of add_edge_crossings (depth_complexity.h) in SIMD: Highway,
// compiled once per target and dispatched at run time, every product and sum rounded in the
// same order on every target (no fused multiply-adds), so the result does not depend on the
// machine's vector width.
#pragma once

#include <cstddef>
#include <cstdint>

namespace penumbra::ssv {

// Arrays of light samples are padded to a multiple of this many floats (one AVX-512 vector);
// padded samples must be at the point itself (0, 0, 0): they never cross.
inline constexpr size_t kSamplePad = 16;
inline size_t padded_samples(size_t n) { return (n + kSamplePad - 1) / kSamplePad * kSamplePad; }

// The four linear tests of one edge (relative to the point o, depth_complexity.cpp): a sample
// l crosses iff m . l < 0, u . l - ua > 0 and (alpha . l) (beta . l) < 0.
struct CrossingTests {
  float m[3], u[3], alpha[3], beta[3];
  float ua;
};

// depth[i] += delta for every sample i < padded (padded_samples) that crosses.
void add_crossings(const CrossingTests& tests, const float* x, const float* y, const float* z, size_t padded,
                   int32_t delta, int32_t* depth);

}  // namespace penumbra::ssv
