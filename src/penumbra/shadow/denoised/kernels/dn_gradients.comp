#version 460
// `rt-denoised` on the GPU: every valid slot's screen-space depth gradient within its image
// (atrous_shared.h dn_depth_gradient, the CPU's function).
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
  Vec2s(planes.grad).v[i] = dn_depth_gradient(img, x, y);
}
