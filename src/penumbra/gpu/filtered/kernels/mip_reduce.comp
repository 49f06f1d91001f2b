#version 460
// A mip chain's next level (gpu/filtered/filtered_layout_shared.h; MipChain::build): one thread
// per texel and channel, the mean of the 2 x 2 texels below it, summed as the CPU sums them.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/filtered/filtered_layout_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { MipReduceParams p; } pc;

void main() {
  uint i = pn_thread_index();
  uint C = uint(pc.p.channels), s = uint(pc.p.side);
  if (i >= s * s * C) return;
  uint c = i % C, texel = i / C;
  uint x = texel % s, y = texel / s, fine = 2u * s;
  Floats t = Floats(pc.p.texels);
  uint a = pc.p.fine_offset + ((2u * y) * fine + 2u * x) * C + c, b = a + fine * C;
  precise float mean = 0.25f * ((t.v[a] + t.v[a + C]) + (t.v[b] + t.v[b + C]));
  t.v[pc.p.coarse_offset + i] = mean;
}
