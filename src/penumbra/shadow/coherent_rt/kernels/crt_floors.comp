#version 460
// `coherent-rt` on the GPU, a reference image's floors (agrawala2000 §5.1; reference_images_shared.h
// crt_floor_of): one thread per texel, its biased floor in window depth (+inf where empty).
#include "penumbra/shadow/coherent_rt/kernels/crt_build.glsl"

void main() {
  uint i = pn_thread_index();
  if (i >= uint(pc.p.width) * uint(pc.p.height)) return;
  CrtTexelsRef t = build_texels();
  int x = int(i % uint(pc.p.width)), y = int(i / uint(pc.p.width));
  Floats(pc.p.floors).v[i] = crt_covered(t, int(i)) ? crt_floor_of(t, RasterViewRef(pc.p.view).v, pc.p.options, x, y) : pn_inf();
}
