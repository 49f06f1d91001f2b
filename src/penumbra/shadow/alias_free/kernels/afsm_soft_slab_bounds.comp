#version 460
// afsm on the GPU: each depth slab's bounding box of the texels that hold its lists (the casters
// pass clips every influence region to it: a region's rows outside it would test nothing). One
// thread per (slab, texel row), on the scanned list starts: a row with entries finds its first
// and last non-empty texel by binary search (the starts never decrease along a row) and widens
// the slab's box (AfsmSlabs::box).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"
#include "penumbra/shadow/alias_free/kernels/afsm_soft_access.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmSoftParams p; } pc;

void main() {
  uint i = pn_thread_index();
  RasterView view = RasterViewRef(pc.p.view).v;
  uint w = uint(view.width), h = uint(view.height);
  if (i >= pc.p.slabs * h) return;
  uint slab = i / h, y = i % h;
  Uints first = Uints(pc.p.first);
  uint row = slab * w * h + y * w;
  uint begin = first.v[row], end = first.v[row + w];
  if (begin == end) return;
  // The first texel x whose list ends past `begin`, and the last whose list starts before `end`.
  uint lo = 0u, hi = w - 1u;
  while (lo < hi) {
    uint mid = (lo + hi) / 2u;
    if (first.v[row + mid + 1u] > begin) hi = mid;
    else lo = mid + 1u;
  }
  uint x_min = lo;
  lo = 0u, hi = w - 1u;
  while (lo < hi) {
    uint mid = (lo + hi + 1u) / 2u;
    if (first.v[row + mid] < end) lo = mid;
    else hi = mid - 1u;
  }
  AfsmSlabsRef slabs = afsm_slabs(pc.p.view);
  uint b = 4u * slab;
  atomicMax(slabs.s.box[b], ~x_min);
  atomicMax(slabs.s.box[b + 1u], ~y);
  atomicMax(slabs.s.box[b + 2u], lo + 1u);
  atomicMax(slabs.s.box[b + 3u], y + 1u);
}
