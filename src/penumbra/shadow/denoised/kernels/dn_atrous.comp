#version 460
// `rt-denoised` on the GPU: one a-trous pass of SVGF's spatial filter (Schied et al. 2017 §4.2)
// at every valid slot (atrous_shared.h dn_atrous, the CPU's function): the image of set
// `current` filtered into the other set.
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
  DenoiseFiltered f =
      dn_atrous(img, Vec2s(planes.grad), Floats(planes.prefiltered).v[i], x, y, pc.p.step, dn_settings(pc.p));
  uint next = 1u - pc.p.current;
  Floats(planes.shadowed[next]).v[i] = f.shadowed;
  Floats(planes.unshadowed[next]).v[i] = f.unshadowed;
  Floats(planes.area[next]).v[i] = f.area;
  Floats(planes.variance[next]).v[i] = f.variance;
}
