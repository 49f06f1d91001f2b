#version 460
// `lam`'s warp on the GPU (agrawala2000 §4, procedure Precompute, line 5; attenuation_map.cpp
// Builder's warp): one thread per pixel of one light sample's depth map. A covered pixel is warped
// into the reference view by eq. 3 and its depth carried along the surface's local plane to the
// centres of the 4 texels around it (lam_shared.h, the CPU's); each of those texels gets the splat
// in its list (LamSplatEntry: the pixel, for the CPU's scan order, and the depth). A list that is
// full still counts the splat: its texel then gathers this sample's splats itself
// (lam_insert.comp), so none is lost.
#include "penumbra/shadow/lam/lam_access.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { LamInsertParams p; } pc;
layout(buffer_reference, scalar) readonly buffer SampleViewRef { LamSampleView v; };
layout(buffer_reference, scalar) buffer SplatLists { LamSplatEntry v[]; };

void main() {
  uint pixel = pn_thread_index();
  if (pixel >= pc.p.pixels) return;
  LamSampleView sv = SampleViewRef(pc.p.view).v;
  int x = int(pixel % uint(sv.width)), y = int(pixel / uint(sv.width));
  Uint64s keys = Uint64s(pc.p.keys);
  float z = lam_sample_depth(keys, sv, x, y);
  if (!(z < pn_inf())) return;
  LamSplat s;
  int W = pc.p.width, H = pc.p.height;
  if (!lam_pixel_splat(keys, sv, x, y, z, W, H, pc.p.slope != 0u, s)) return;
  Uints list_counts = Uints(pc.p.list_counts);
  SplatLists lists = SplatLists(pc.p.lists);
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      int tx = s.ix + i, ty = s.iy + j;
      if (tx < 0 || ty < 0 || tx >= W || ty >= H) continue;
      uint t = uint(ty) * uint(W) + uint(tx);
      uint slot = atomicAdd(list_counts.v[t], 1u);
      if (slot < pc.p.list_capacity)
        lists.v[t * pc.p.list_capacity + slot] = LamSplatEntry(pixel, lam_splat_depth(s, i, j), lam_splat_weight(s, i, j));
    }
}
