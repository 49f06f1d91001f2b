#version 460
// `rt-denoised` on the GPU, below 4 light samples: SVGF §4.1's spatial variance of every valid
// slot (atrous_shared.h dn_spatial_variance, the CPU's function) into the `prefiltered` plane;
// the host copies it over the variance afterwards (every pixel reads its neighbours' V first).
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
  Floats(planes.prefiltered).v[i] = dn_valid(img, i) ? dn_spatial_variance(img, Vec2s(planes.grad), x, y, dn_settings(pc.p)) : 0.0f;
}
