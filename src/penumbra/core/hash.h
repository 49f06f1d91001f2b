// Non-cryptographic digests for cache keys (the reference cache, the map cache): they tell
// inputs apart against accidental change, not against an adversary.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>

namespace penumbra {

inline constexpr uint64_t kFnvOffsetBasis = 0xcbf29ce484222325ull;

// FNV-1a over the bytes of `s` (last to first with `reverse`), from `basis`.
uint64_t fnv1a(std::string_view s, uint64_t basis = kFnvOffsetBasis, bool reverse = false);

// A 128-bit digest of a sequence of byte blocks, eight bytes at a time (a mesh of a million
// triangles hashes in a few milliseconds, where byte-wise FNV takes ten times as long). The
// digest depends on the bytes and on where each add() starts a block, so add the fields of a
// record in a fixed order.
class Digest128 {
 public:
  void add(const void* data, size_t bytes);
  void add(std::string_view text) {
    add_value(static_cast<uint64_t>(text.size()));
    add(text.data(), text.size());
  }
  // One value of a type without padding bytes (floats, integers, Vec3f): padding would
  // hash whatever the bytes happen to hold.
  template <class T>
  void add_value(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    add(&value, sizeof(T));
  }
  // 32 hex digits.
  std::string hex() const;

 private:
  uint64_t a_ = 0x9e3779b97f4a7c15ull, b_ = kFnvOffsetBasis;
  uint64_t length_ = 0;
};

}  // namespace penumbra
