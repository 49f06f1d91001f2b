// Counter-based random numbers. Every random decision in penumbra is a pure function of
// (seed, pixel, light, sample, dimension), so an image does not depend on the thread
// count or the order in which tiles are scheduled (DESIGN.md, conventions), nor on which
// pixels are rendered: a view sample's key is its camera ray (sample_key, view_samples.h).
#pragma once

#include <cstdint>

#include "penumbra/core/math.h"

namespace penumbra {

// A strong 64-bit mixer (the splitmix64 / Stafford "Mix13" finalizer).
inline uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

inline uint64_t hash_combine(uint64_t a, uint64_t b) { return mix64(a ^ (b + 0x9e3779b97f4a7c15ULL + (a << 6) + (a >> 2))); }

// Uniform float in [0,1) from the top 24 bits.
inline float bits_to_unit_float(uint64_t bits) { return static_cast<float>(bits >> 40) * 0x1p-24f; }

// A stream of random numbers identified by a key. next() walks a counter, so two
// streams with different keys are independent and the n-th number is reproducible.
class Rng {
 public:
  Rng() = default;
  explicit Rng(uint64_t key) : key_(mix64(key)) {}
  Rng(uint64_t seed, uint64_t a, uint64_t b = 0, uint64_t c = 0)
      : key_(hash_combine(hash_combine(hash_combine(mix64(seed), a), b), c)) {}
  uint64_t next_u64() { return mix64(key_ + 0x9e3779b97f4a7c15ULL * ++counter_); }
  uint32_t next_u32() { return static_cast<uint32_t>(next_u64() >> 32); }
  float next_float() { return bits_to_unit_float(next_u64()); }
  Vec2f next_2d() { float a = next_float(); return {a, next_float()}; }
  // Uniform integer in [0, n).
  uint32_t uniform_int(uint32_t n) { return static_cast<uint32_t>((static_cast<uint64_t>(next_u32()) * n) >> 32); }

 private:
  uint64_t key_ = 0;
  uint64_t counter_ = 0;
};

}  // namespace penumbra
