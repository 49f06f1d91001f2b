#include "penumbra/core/hash.h"

#include <cstring>

#include <fmt/format.h>

namespace penumbra {

uint64_t fnv1a(std::string_view s, uint64_t basis, bool reverse) {
  uint64_t h = basis;
  const size_t n = s.size();
  for (size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(reverse ? s[n - 1 - i] : s[i]);
    h *= 0x100000001b3ull;
  }
  return h;
}

namespace {
inline uint64_t rotl(uint64_t x, int r) { return (x << r) | (x >> (64 - r)); }
// splitmix64's finaliser: every input bit reaches every output bit.
inline uint64_t mix(uint64_t x) {
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}
}  // namespace

void Digest128::add(const void* data, size_t bytes) {
  const auto* p = static_cast<const unsigned char*>(data);
  // Two independent lanes (an xxhash-style round and FNV over words), so a collision needs
  // both to collide.
  auto round = [this](uint64_t w) {
    a_ = rotl(a_ + w * 0xc2b2ae3d27d4eb4full, 31) * 0x9e3779b97f4a7c15ull;
    b_ = (b_ ^ w) * 0x100000001b3ull;
  };
  size_t i = 0;
  for (; i + 8 <= bytes; i += 8) {
    uint64_t w;
    std::memcpy(&w, p + i, 8);
    round(w);
  }
  if (i < bytes) {
    uint64_t w = 0;
    std::memcpy(&w, p + i, bytes - i);
    round(w ^ (static_cast<uint64_t>(bytes - i) << 59));
  }
  length_ += bytes;
  round(0x6a09e667f3bcc909ull ^ bytes);  // block boundary
}

std::string Digest128::hex() const {
  return fmt::format("{:016x}{:016x}", mix(a_ ^ length_), mix(b_ + rotl(a_, 17)));
}

}  // namespace penumbra
