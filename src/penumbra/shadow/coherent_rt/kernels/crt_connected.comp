#version 460
// `coherent-rt` on the GPU, one level of a reference image's connectedness quadtree
// (agrawala2000 §5.1.1; reference_images_shared.h crt_node_connected_of): one thread per node of
// level pc.p.level, from the level below.
#include "penumbra/shadow/coherent_rt/kernels/crt_build.glsl"

void main() {
  DepthPyramidRef pyr = depth_pyramid_ref(pc.p.nodes, pc.p.levels, pc.p.level_count);
  int level = pc.p.level;
  int width = depth_pyramid_width(pyr, level);
  uint i = pn_thread_index();
  if (i >= uint(width) * uint(depth_pyramid_height(pyr, level))) return;
  int x = int(i % uint(width)), y = int(i / uint(width));
  CrtConnectedRef c;
  c.nodes = pc.p.connected;
  bool connected = crt_node_connected_of(build_texels(), c, pyr, level, x, y);
  Uints(pc.p.connected).v[depth_pyramid_index(pyr, level, x, y)] = connected ? 1u : 0u;
}
