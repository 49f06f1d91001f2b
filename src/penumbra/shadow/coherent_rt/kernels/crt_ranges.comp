#version 460
// `coherent-rt` on the GPU, level 0 of a reference image's min/max pyramid (its floor and the
// walls to its connected neighbours: reference_images_shared.h crt_range_of) and of its
// connectedness quadtree (a texel holding a surface is connected to itself): one thread per texel.
#include "penumbra/shadow/coherent_rt/kernels/crt_build.glsl"

void main() {
  uint i = pn_thread_index();
  if (i >= uint(pc.p.width) * uint(pc.p.height)) return;
  CrtTexelsRef t = build_texels();
  int x = int(i % uint(pc.p.width)), y = int(i / uint(pc.p.width));
  Vec2s(pc.p.nodes).v[i] = crt_range_of(t, x, y);
  Uints(pc.p.connected).v[i] = crt_texel_floor(t, int(i)) < pn_inf() ? 1u : 0u;
}
