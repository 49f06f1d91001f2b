// The per-texel steps of a reference image (agrawala2000 §5.1: floors and walls; §5.1.1: the
// connectedness quadtree) in the common subset of C++ and GLSL (core/shader_compat.h): the CPU's
// build_reference_image (reference_images.cpp) and the GPU's kernels (kernels/crt_*.comp) run each
// texel and node through these functions. A texel's inputs (the depth map, the links, the floors,
// the children's connectedness) are read through the accessors of the two branches below.
#ifndef PENUMBRA_SHADOW_COHERENT_RT_REFERENCE_IMAGES_SHARED_H
#define PENUMBRA_SHADOW_COHERENT_RT_REFERENCE_IMAGES_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/depth_image_walk_shared.h"
#include "penumbra/raster/raster_shared.h"

PN_SHARED_BEGIN

// Neighbour k of a texel (reference_images.h kNeighbourDx, kNeighbourDy): the 4 edge neighbours
// (k < 4), then the 4 diagonal ones.
PN_INLINE int crt_neighbour_dx(int k) { return (k == 0 || k == 4 || k == 6) ? 1 : ((k == 1 || k == 5 || k == 7) ? -1 : 0); }
PN_INLINE int crt_neighbour_dy(int k) { return (k == 2 || k == 4 || k == 5) ? 1 : ((k == 3 || k == 6 || k == 7) ? -1 : 0); }

// LightView::texel_world_size: the world width of a texel at linear depth z.
PN_INLINE float view_texel_world_size(PN_IN(RasterView) v, float z) {
  float size = (v.r - v.l) / float(v.width);
  return v.perspective != 0u ? size * z / v.near : size;
}

// The build's settings (ReferenceImageOptions' biases, in texels), 16 bytes.
struct CrtBuildOptions {
  float gap_bias;
  float shadow_bias;       // floors of closed objects' surfaces
  float slope_bias;
  float open_shadow_bias;  // floors of open surfaces (SceneObject::closed false: leaves, cards, planes)
};

PN_SHARED_END

#ifdef __cplusplus
namespace penumbra::shader {
// A texel grid's planes: the depth map's linear depths and triangles, the links and the floors.
struct CrtTexels {
  const float* z;
  const uint* triangle;
  const uint8_t* links;
  const float* floors;
  int width;
  int height;
};
using CrtTexelsRef = const CrtTexels&;
inline bool crt_covered(CrtTexelsRef t, int i) { return t.triangle[i] != 0xffffffffu; }
inline float crt_z(CrtTexelsRef t, int i) { return t.z[i]; }
inline uint crt_texel_links(CrtTexelsRef t, int i) { return t.links[i]; }
inline float crt_texel_floor(CrtTexelsRef t, int i) { return t.floors[i]; }
// The connectedness quadtree being built: one byte per node, level by level.
using CrtConnectedRef = const std::vector<std::vector<uint8_t>>&;
inline bool crt_connected_at(CrtConnectedRef c, DepthPyramidRef p, int level, int x, int y) {
  return c[level][static_cast<size_t>(y) * static_cast<size_t>(depth_pyramid_width(p, level)) + x] != 0;
}
}  // namespace penumbra::shader
#else
struct CrtTexelsRef {
  uint64_t z;         // float per texel (the GPU depth map's z plane)
  uint64_t triangle;  // uint per texel (its triangle plane)
  uint64_t links;     // uint per texel
  uint64_t floors;    // float per texel
  int width;
  int height;
};
bool crt_covered(CrtTexelsRef t, int i) { return Uints(t.triangle).v[i] != 0xffffffffu; }
float crt_z(CrtTexelsRef t, int i) { return Floats(t.z).v[i]; }
uint crt_texel_links(CrtTexelsRef t, int i) { return Uints(t.links).v[i]; }
float crt_texel_floor(CrtTexelsRef t, int i) { return Floats(t.floors).v[i]; }
// uint per pyramid node, in the pyramid's layout.
struct CrtConnectedRef {
  uint64_t nodes;
};
bool crt_connected_at(CrtConnectedRef c, DepthPyramidRef p, int level, int x, int y) {
  return Uints(c.nodes).v[depth_pyramid_index(p, level, x, y)] != 0u;
}
#endif

PN_SHARED_BEGIN

// The walls of texel (x, y) (covered): bit k set when neighbour k holds a surface whose depth
// differs by at most gap_bias texel widths (at the nearer of the two depths; sqrt 2 more for a
// diagonal).
PN_INLINE uint crt_links_of(CrtTexelsRef t, PN_IN(RasterView) v, float gap_bias, int x, int y) {
  int i = y * t.width + x;
  float z = crt_z(t, i);
  uint links = 0u;
  for (int k = 0; k < 8; ++k) {
    int nx = x + crt_neighbour_dx(k);
    int ny = y + crt_neighbour_dy(k);
    if (nx < 0 || ny < 0 || nx >= t.width || ny >= t.height) continue;
    int j = ny * t.width + nx;
    if (!crt_covered(t, j)) continue;
    // Symmetric: the gap is measured at the nearer of the two depths.
    float zj = crt_z(t, j);
    float gap = gap_bias * view_texel_world_size(v, min(z, zj)) * (k >= 4 ? 1.41421356f : 1.0f);
    if (abs(z - zj) <= gap) links |= 1u << uint(k);
  }
  return links;
}

// The floor of texel (x, y) (covered), window depth: pushed back by shadow_bias texel widths plus,
// slope-scaled, the largest depth step to a connected edge neighbour (a surface seen at a grazing
// angle moves that much per texel, so a point anywhere in the texel lies up to about that far
// behind the sampled depth). `closed`: the texel's surface belongs to a closed object, whose
// curved faces need the full shadow_bias against self-shadowing; an open surface (a leaf, a card,
// a ground plane) is flat per triangle, its slope term covers it, and open_shadow_bias (less)
// keeps a leaf's shadow on the leaves just below it (issue 34: the forest's crowns read too
// bright, mean signed +0.033, with 1.5 texels everywhere).
PN_INLINE float crt_floor_of(CrtTexelsRef t, PN_IN(RasterView) v, CrtBuildOptions o, int x, int y, bool closed) {
  int i = y * t.width + x;
  float z = crt_z(t, i);
  uint links = crt_texel_links(t, i);
  float step = 0.0f;
  for (int k = 0; k < 4; ++k)
    if ((links & (1u << uint(k))) != 0u)
      step = dw_max(step, abs(crt_z(t, (y + crt_neighbour_dy(k)) * t.width + x + crt_neighbour_dx(k)) - z));
  float bias = closed ? o.shadow_bias : o.open_shadow_bias;
  return view_window_depth(v, z + bias * view_texel_world_size(v, z) + o.slope_bias * step);
}

// Texel (x, y)'s range in the pyramid: its floor and the walls to its connected neighbours (a ray
// crossing a wall at the texel's edge overlaps the range there). Empty where no floor.
PN_INLINE vec2 crt_range_of(CrtTexelsRef t, int x, int y) {
  int i = y * t.width + x;
  float f = crt_texel_floor(t, i);
  if (f == uintBitsToFloat(0x7f800000u)) return vec2(f, -f);
  vec2 r = vec2(f, f);
  uint links = crt_texel_links(t, i);
  for (int k = 0; k < 8; ++k) {
    if ((links & (1u << uint(k))) == 0u) continue;
    float g = crt_texel_floor(t, (y + crt_neighbour_dy(k)) * t.width + x + crt_neighbour_dx(k));
    r.x = dw_min(r.x, g);
    r.y = dw_max(r.y, g);
  }
  return r;
}

// Node (x, y) of `level` >= 1 of the connectedness quadtree (§5.1.1): connected when its children
// are and every edge-adjacent pair across the children's shared borders is linked.
PN_INLINE bool crt_node_connected_of(CrtTexelsRef t, CrtConnectedRef c, DepthPyramidRef p, int level, int x, int y) {
  int cw = depth_pyramid_width(p, level - 1);
  int ch = depth_pyramid_height(p, level - 1);
  for (int cy = 2 * y; cy < min(2 * y + 2, ch); ++cy)
    for (int cx = 2 * x; cx < min(2 * x + 2, cw); ++cx)
      if (!crt_connected_at(c, p, level - 1, cx, cy)) return false;
  int x0 = x << level;
  int y0 = y << level;
  int x1 = min(t.width, (x + 1) << level);
  int y1 = min(t.height, (y + 1) << level);
  int xm = x0 + (1 << (level - 1));
  int ym = y0 + (1 << (level - 1));
  // Bit 0: the neighbour at (+1, 0); bit 2: at (0, +1).
  if (xm < x1)
    for (int ty = y0; ty < y1; ++ty)
      if ((crt_texel_links(t, ty * t.width + xm - 1) & 1u) == 0u) return false;
  if (ym < y1)
    for (int tx = x0; tx < x1; ++tx)
      if ((crt_texel_links(t, (ym - 1) * t.width + tx) & 4u) == 0u) return false;
  return true;
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::CrtBuildOptions) == 16);
#endif

#endif  // PENUMBRA_SHADOW_COHERENT_RT_REFERENCE_IMAGES_SHARED_H
