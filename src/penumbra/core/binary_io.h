// Plain binary records on streams, for data a program writes and the same build reads back
// (the map cache's entries, render/map_cache.h): values in the machine's own layout, arrays
// with their length first. Readers return false on a short or implausible record instead of
// throwing, so a damaged file reads as "not there".
#pragma once

#include <cstdint>
#include <istream>
#include <ostream>
#include <type_traits>
#include <vector>

namespace penumbra::binary {

template <class T>
void write(std::ostream& out, const T& value) {
  static_assert(std::is_trivially_copyable_v<T>);
  out.write(reinterpret_cast<const char*>(&value), sizeof(T));
}

template <class T>
void write_array(std::ostream& out, const std::vector<T>& values) {
  static_assert(std::is_trivially_copyable_v<T>);
  write<uint64_t>(out, values.size());
  out.write(reinterpret_cast<const char*>(values.data()), static_cast<std::streamsize>(values.size() * sizeof(T)));
}

template <class T>
bool read(std::istream& in, T& value) {
  static_assert(std::is_trivially_copyable_v<T>);
  return static_cast<bool>(in.read(reinterpret_cast<char*>(&value), sizeof(T)));
}

// At most max_count elements: a damaged length never allocates the machine's memory.
template <class T>
bool read_array(std::istream& in, std::vector<T>& values, uint64_t max_count) {
  static_assert(std::is_trivially_copyable_v<T>);
  uint64_t n = 0;
  if (!read(in, n) || n > max_count) return false;
  values.resize(n);
  return static_cast<bool>(in.read(reinterpret_cast<char*>(values.data()), static_cast<std::streamsize>(n * sizeof(T))));
}

}  // namespace penumbra::binary
