#version 460
// `rt-denoised` on the GPU: V of every valid slot, the ratio of the denoised estimates (Heitz et
// al. 2018 §3.2; atrous_shared.h dn_ratio, the CPU's function).
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
  Floats(pc.p.visibility).v[i] = dn_ratio(img, i);
}
