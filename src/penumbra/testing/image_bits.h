// Bit-for-bit image equality for tests of determinism and reuse (frames, tiles, renderers).
#pragma once

#include <cstring>

#include "penumbra/core/image.h"

namespace penumbra::testing {

// Same size, channels and every float's bits (so -0 differs from 0, and NaN equals itself).
inline bool same_bits(const Image& a, const Image& b) {
  return a.width() == b.width() && a.height() == b.height() && a.channels() == b.channels() &&
         std::memcmp(a.data().data(), b.data().data(), a.data().size() * sizeof(float)) == 0;
}

}  // namespace penumbra::testing
