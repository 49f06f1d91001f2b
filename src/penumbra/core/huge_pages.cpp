#include "penumbra/core/huge_pages.h"

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>

namespace penumbra {

namespace {

constexpr std::string_view kTunable = "glibc.malloc.hugetlb";

// The value GLIBC_TUNABLES gives glibc.malloc.hugetlb ("" if it gives none). The variable is a
// colon-separated list of name=value.
std::string tunable_value(const char* tunables) {
  if (!tunables) return {};
  std::string_view list = tunables;
  while (!list.empty()) {
    const size_t colon = list.find(':');
    const std::string_view item = list.substr(0, colon);
    if (item.size() > kTunable.size() && item.substr(0, kTunable.size()) == kTunable && item[kTunable.size()] == '=')
      return std::string(item.substr(kTunable.size() + 1));
    if (colon == std::string_view::npos) break;
    list.remove_prefix(colon + 1);
  }
  return {};
}

// ASan's and TSan's allocators replace glibc's malloc, which then never reads the tunable
// (g++ says so with __SANITIZE_*__, clang with __has_feature).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitizerAllocator = true;
#elif defined(__has_feature)
constexpr bool kSanitizerAllocator = __has_feature(address_sanitizer) || __has_feature(thread_sanitizer);
#else
constexpr bool kSanitizerAllocator = false;
#endif

}  // namespace

std::string bracketed_mode(std::string_view text) {
  const size_t open = text.find('[');
  if (open == std::string_view::npos) return {};
  const size_t close = text.find(']', open);
  if (close == std::string_view::npos) return {};
  return std::string(text.substr(open + 1, close - open - 1));
}

std::string transparent_huge_pages_mode() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  if (!in) return {};
  std::stringstream text;
  text << in.rdbuf();
  return bracketed_mode(text.str());
}

bool huge_pages_available() {
  if (kSanitizerAllocator) return false;
  const std::string mode = transparent_huge_pages_mode();
  return mode == "always" || mode == "madvise";
}

bool heap_uses_huge_pages() {
  if (kSanitizerAllocator) return false;
  const std::string value = tunable_value(std::getenv("GLIBC_TUNABLES"));
  // 1: transparent pages, where the kernel offers them; 2: the preallocated pool (hugetlbfs).
  return (value == "1" && huge_pages_available()) || value == "2";
}

void reexec_with_huge_pages(char** argv) {
  if (const char* off = std::getenv("PENUMBRA_HUGE_PAGES"); off && std::string_view(off) == "0") return;
  // Under valgrind (its preload in LD_PRELOAD) the tool's malloc stands in for glibc's, and an
  // exec would leave the tool: callgrind would measure nothing.
  const char* preload = std::getenv("LD_PRELOAD");
  if (preload && std::string_view(preload).find("vgpreload") != std::string_view::npos) return;
  const char* given = std::getenv("GLIBC_TUNABLES");
  const std::optional<std::string> tunables = given ? std::optional<std::string>(given) : std::nullopt;
  // Said already, either way (by the user, or by this function in the process that executed
  // this one): never executed twice.
  if (tunables && tunables->find(kTunable) != std::string::npos) return;
  if (!huge_pages_available()) return;
  const std::string value = (tunables && !tunables->empty() ? *tunables + ":" : std::string()) +
                            std::string(kTunable) + "=1";
  if (setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  // exec failed (no /proc): carry on with 4 KiB pages, and say so to no one (it is only speed).
  if (tunables)
    setenv("GLIBC_TUNABLES", tunables->c_str(), 1);
  else
    unsetenv("GLIBC_TUNABLES");
}

}  // namespace penumbra
