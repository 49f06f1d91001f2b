#version 460
// The batch mode's resolve (gpu/raster/raster_batch_layout_shared.h): one thread per texel of all
// views, its view found by binary search over the views' first texels; the key into the z and
// opacity planes (raster_resolve_key, the one mode's resolve).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_batch_layout_shared.h"
#include "penumbra/gpu/raster/raster_stages.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { RasterBatchResolveParams p; } pc;
layout(buffer_reference, scalar) readonly buffer BatchViews { GpuRasterBatchView v[]; };

void main() {
  uint i = pn_thread_index();  // a batch holds fewer than 2^32 texels (GpuBatchRasterizer)
  if (uint64_t(i) >= pc.p.texels) return;
  BatchViews views = BatchViews(pc.p.views);
  // The last view whose first texel is <= i.
  uint lo = 0u, hi = pc.p.view_count;
  while (hi - lo > 1u) {
    uint mid = (lo + hi) / 2u;
    if (views.v[mid].first_texel <= uint64_t(i)) lo = mid;
    else hi = mid;
  }
  RasterView view = views.v[lo].view;
  uint local = i - uint(views.v[lo].first_texel);
  uint64_t key = Uint64s(pc.p.keys).v[i];
  if (key != ~0UL) scene_bind(pc.p.scene);
  float z, depth, opacity;
  uint triangle;
  raster_resolve_key(view, key, int(local % uint(view.width)), int(local / uint(view.width)), z, depth, opacity,
                     triangle);
  Floats(pc.p.z).v[i] = z;
  Floats(pc.p.opacity).v[i] = opacity;
}
