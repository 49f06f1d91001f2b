#version 460
// `rt-denoised` on the GPU, each a-trous iteration: the variance prefiltered by SVGF §4.3's 3 x 3
// Gaussian at every valid slot (atrous_shared.h dn_prefiltered_variance, the CPU's function).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/denoised/denoise_image.glsl"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { DnFilterParams p; } pc;

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.slots) return;
  DnPlanes planes = DnPlanesRef(pc.p.planes).p;
  int x, y;
  DenoiseImage img = dn_slot_image(planes, pc.p, i, x, y);
  if (!dn_valid(img, i)) return;
  Floats(planes.prefiltered).v[i] = dn_prefiltered_variance(img, x, y);
}
