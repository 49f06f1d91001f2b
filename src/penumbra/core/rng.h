// Counter-based random numbers. Every random decision in penumbra is a pure function of
// (seed, pixel, light, sample, dimension), so an image does not depend on the thread
// count or the order in which tiles are scheduled (DESIGN.md, conventions), nor on which
// pixels are rendered: a view sample's key is its camera ray (sample_key, view_samples.h).
// The generator itself lives in rng_shared.h, which the GPU kernels include too: both devices
// draw the same numbers for the same key.
#pragma once

#include <cstdint>

#include "penumbra/core/math.h"
#include "penumbra/core/rng_shared.h"

namespace penumbra {

using shader::bits_to_unit_float;
using shader::hash_combine;
using shader::mix64;

// A stream of random numbers identified by a key. next() walks a counter, so two
// streams with different keys are independent and the n-th number is reproducible.
class Rng {
 public:
  Rng() = default;
  explicit Rng(uint64_t key) : state_(shader::rng_from_key(key)) {}
  Rng(uint64_t seed, uint64_t a, uint64_t b = 0, uint64_t c = 0) : state_(shader::rng_keyed(seed, a, b, c)) {}
  uint64_t next_u64() { return shader::rng_next_u64(state_); }
  uint32_t next_u32() { return shader::rng_next_u32(state_); }
  float next_float() { return shader::rng_next_float(state_); }
  Vec2f next_2d() { return shader::rng_next_2d(state_); }
  // Uniform integer in [0, n).
  uint32_t uniform_int(uint32_t n) { return static_cast<uint32_t>((static_cast<uint64_t>(next_u32()) * n) >> 32); }

 private:
  shader::RngState state_{0, 0};
};

}  // namespace penumbra
