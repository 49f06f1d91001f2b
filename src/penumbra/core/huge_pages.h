// Transparent huge pages for the heap.
//
// A render of a wide scene allocates and first touches hundreds of megabytes per frame: the
// casters and their regions (`afsm`), the silhouette edges (`ssv-rt`), the layered depth maps
// (`mlsm`), the gathered triangles. Each first touch of a 4 KiB page is a page fault; on a
// virtual machine a fault traps to the hypervisor. Measured on the development machine
// (`afsm` on the 25-tree forest at 256², 256 samples): 288,000 faults, 2.3 s of system time,
// 17% of the samples under `perf`. On 2 MiB pages: 72,000 faults, and the renders of the
// sample-exact methods take about a fifth less time, on the forest and on the bunny
// (docs/benchmarks.md, "Huge pages").
//
// glibc's malloc asks the kernel for 2 MiB pages (madvise(MADV_HUGEPAGE) on its heaps and its
// mmapped chunks, 2 MiB-aligned) only when the tunable glibc.malloc.hugetlb=1 is set, and it
// reads tunables once, as the process starts. So the command line re-executes itself once with
// it set (`reexec_with_huge_pages`, the first thing main() does), as Java's launcher re-executes
// itself to set the loader's path. The Python module cannot: start Python with
// GLIBC_TUNABLES=glibc.malloc.hugetlb=1 for the same effect (docs/python.md).
#pragma once

#include <string>
#include <string_view>

namespace penumbra {

// The kernel's transparent huge page mode, the bracketed word of
// /sys/kernel/mm/transparent_hugepage/enabled ("always", "madvise", "never"), or "" where the
// file is missing (no THP, another OS).
std::string transparent_huge_pages_mode();
// The bracketed word of that file's text: "always [madvise] never" -> "madvise"; "" if none.
std::string bracketed_mode(std::string_view enabled_file_text);

// True where glibc's malloc can be put on huge pages: the kernel offers them ("always" or
// "madvise") and no sanitizer's allocator stands in for glibc's.
bool huge_pages_available();

// True when this process's malloc asks for huge pages: the kernel offers them ("always" or
// "madvise") and GLIBC_TUNABLES held glibc.malloc.hugetlb=1 (or 2, preallocated pages) at start.
bool heap_uses_huge_pages();

// For main(): where the kernel offers huge pages and GLIBC_TUNABLES does not already say
// glibc.malloc.hugetlb, adds glibc.malloc.hugetlb=1 to it and executes /proc/self/exe again
// with the same arguments. Returns (nothing changed) where it does not: PENUMBRA_HUGE_PAGES=0,
// a sanitizer's or valgrind's allocator in place of glibc's, no /proc, or exec failing.
void reexec_with_huge_pages(char** argv);

}  // namespace penumbra
