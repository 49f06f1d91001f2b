// The counter-based random generator (core/rng.h's Rng) in the common subset of C++ and GLSL
// (core/shader_compat.h): the GPU kernels draw exactly the integers the CPU draws for the same
// key, so a CPU and a GPU render at one seed use the same light samples (issue 28 part 5).
// Tested bit for bit on both sides (gpu/shared_functions_test.cpp).
#ifndef PENUMBRA_CORE_RNG_SHARED_H
#define PENUMBRA_CORE_RNG_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// A strong 64-bit mixer (the splitmix64 / Stafford "Mix13" finalizer).
PN_INLINE uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9UL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebUL;
  return z ^ (z >> 31);
}

PN_INLINE uint64_t hash_combine(uint64_t a, uint64_t b) {
  return mix64(a ^ (b + 0x9e3779b97f4a7c15UL + (a << 6) + (a >> 2)));
}

// Uniform float in [0,1) from the top 24 bits (2^-24 = 5.9604644775390625e-8, exact).
PN_INLINE float bits_to_unit_float(uint64_t bits) { return float(bits >> 40) * 5.9604644775390625e-8f; }

// A stream identified by a key: the n-th number is mix64(key + golden * n).
struct RngState {
  uint64_t key;
  uint64_t counter;
};

// Rng(seed, a, b, c) of core/rng.h.
PN_INLINE RngState rng_keyed(uint64_t seed, uint64_t a, uint64_t b, uint64_t c) {
  RngState r;
  r.key = hash_combine(hash_combine(hash_combine(mix64(seed), a), b), c);
  r.counter = 0UL;
  return r;
}
// Rng(key) of core/rng.h.
PN_INLINE RngState rng_from_key(uint64_t key) {
  RngState r;
  r.key = mix64(key);
  r.counter = 0UL;
  return r;
}
PN_INLINE uint64_t rng_next_u64(PN_INOUT(RngState) r) {
  r.counter = r.counter + 1UL;
  return mix64(r.key + 0x9e3779b97f4a7c15UL * r.counter);
}
PN_INLINE uint rng_next_u32(PN_INOUT(RngState) r) { return uint(rng_next_u64(r) >> 32); }
PN_INLINE float rng_next_float(PN_INOUT(RngState) r) { return bits_to_unit_float(rng_next_u64(r)); }
PN_INLINE vec2 rng_next_2d(PN_INOUT(RngState) r) {
  float a = rng_next_float(r);
  return vec2(a, rng_next_float(r));
}

PN_SHARED_END

#endif  // PENUMBRA_CORE_RNG_SHARED_H
