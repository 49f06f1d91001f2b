// Errors are exceptions whose message names the file, key or value at fault; the CLI
// turns them into one line on stderr and a non-zero exit (DESIGN.md, conventions).
#pragma once

#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace penumbra {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& msg) : std::runtime_error(msg) {}
  template <typename... Args>
  explicit Error(fmt::format_string<Args...> f, Args&&... args)
      : std::runtime_error(fmt::format(f, std::forward<Args>(args)...)) {}
};

}  // namespace penumbra
