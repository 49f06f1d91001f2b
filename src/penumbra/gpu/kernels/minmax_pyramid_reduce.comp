#version 460
// One level of a min/max pyramid from the level below (gpu/minmax_pyramid_shared.h;
// raster/minmax_pyramid.cpp build_levels): one thread per parent node, the range of its two to
// four children (one or two at an odd edge). Empty children are (+inf, -inf) and change nothing.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/minmax_pyramid_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { MinMaxPyramidReduceParams p; } pc;

void main() {
  uint i = pn_thread_index();
  if (i >= uint(pc.p.parent_width) * uint(pc.p.parent_height)) return;
  int x = int(i % uint(pc.p.parent_width)), y = int(i / uint(pc.p.parent_width));
  Vec2s nodes = Vec2s(pc.p.nodes);
  float lo = pn_inf(), hi = -pn_inf();
  for (int cy = 2 * y; cy < min(pc.p.child_height, 2 * y + 2); ++cy)
    for (int cx = 2 * x; cx < min(pc.p.child_width, 2 * x + 2); ++cx) {
      vec2 r = nodes.v[pc.p.child_offset + uint(cy) * uint(pc.p.child_width) + uint(cx)];
      lo = min(lo, r.x);
      hi = max(hi, r.y);
    }
  nodes.v[pc.p.parent_offset + i] = vec2(lo, hi);
}
