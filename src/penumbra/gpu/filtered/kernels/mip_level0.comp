#version 460
// A mip chain's level 0 (gpu/filtered/filtered_layout_shared.h; MipChain::build): one thread per
// texel and channel of the side x side square, the map's value where the map is, the outside
// value beyond it.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/filtered/filtered_layout_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { MipLevel0Params p; } pc;

void main() {
  uint i = pn_thread_index();
  uint C = uint(pc.p.channels);
  if (i >= uint(pc.p.side) * uint(pc.p.side) * C) return;
  uint c = i % C, texel = i / C;
  int x = int(texel % uint(pc.p.side)), y = int(texel / uint(pc.p.side));
  bool inside = x < pc.p.width && y < pc.p.height;
  Floats(pc.p.texels).v[i] =
      inside ? Floats(pc.p.source).v[(uint(y) * uint(pc.p.width) + uint(x)) * C + c] : pc.p.outside[c];
}
