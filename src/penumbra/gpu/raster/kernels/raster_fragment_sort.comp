#version 460
// The GPU rasterizer's fragment lists, last pass (gpu/raster/raster_modes_shared.h): one thread
// per texel sorts its list by (z, input triangle), the CPU's order (raster_depth_key: unique per
// texel, so any sort gives the same list). Insertion sort for the short lists of most texels, heap
// sort (in place, n log n) for deep ones (hair, foliage).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_modes_shared.h"
#include "penumbra/raster/raster_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterFragmentSortParams p; } pc;
layout(buffer_reference, scalar) buffer GpuFragments { GpuFragment v[]; };

uint64_t fragment_key(GpuFragment f) { return raster_depth_key(f.z, f.triangle); }

// Moves the element at `root` down the max-heap f[first, first + n).
void sift_down(GpuFragments f, uint first, uint root, uint n) {
  GpuFragment x = f.v[first + root];
  uint64_t key = fragment_key(x);
  for (;;) {
    uint child = 2u * root + 1u;
    if (child >= n) break;
    if (child + 1u < n && fragment_key(f.v[first + child + 1u]) > fragment_key(f.v[first + child])) child += 1u;
    if (!(fragment_key(f.v[first + child]) > key)) break;
    f.v[first + root] = f.v[first + child];
    root = child;
  }
  f.v[first + root] = x;
}

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.texels) return;
  Uints offsets = Uints(pc.p.offsets);
  uint first = offsets.v[i], end = offsets.v[i + 1u];
  if (end > pc.p.fragment_capacity || end - first < 2u) return;  // not all written: the host renders again
  GpuFragments f = GpuFragments(pc.p.fragments);
  uint n = end - first;
  if (n <= 32u) {
    for (uint a = 1u; a < n; ++a) {
      GpuFragment x = f.v[first + a];
      uint64_t key = fragment_key(x);
      uint b = a;
      for (; b > 0u && key < fragment_key(f.v[first + b - 1u]); --b) f.v[first + b] = f.v[first + b - 1u];
      f.v[first + b] = x;
    }
    return;
  }
  for (uint root = n / 2u; root-- > 0u;) sift_down(f, first, root, n);
  for (uint last = n - 1u; last > 0u; --last) {
    GpuFragment top = f.v[first];
    f.v[first] = f.v[first + last];
    f.v[first + last] = top;
    sift_down(f, first, 0u, last);
  }
}
