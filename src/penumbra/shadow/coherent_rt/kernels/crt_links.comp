#version 460
// `coherent-rt` on the GPU, a reference image's walls (agrawala2000 §5.1; reference_images_shared.h
// crt_links_of): one thread per texel of the depth map, its connected neighbours.
#include "penumbra/shadow/coherent_rt/kernels/crt_build.glsl"

void main() {
  uint i = pn_thread_index();
  if (i >= uint(pc.p.width) * uint(pc.p.height)) return;
  CrtTexelsRef t = build_texels();
  int x = int(i % uint(pc.p.width)), y = int(i / uint(pc.p.width));
  Uints(pc.p.links).v[i] = crt_covered(t, int(i)) ? crt_links_of(t, RasterViewRef(pc.p.view).v, pc.p.options.gap_bias, x, y) : 0u;
}
