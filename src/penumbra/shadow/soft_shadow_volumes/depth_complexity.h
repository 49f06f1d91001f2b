// The depth-complexity function over a fixed set of light samples as seen from one point
// (Laine et al. 2005 §3.2-3.3): D(l) = the number of caster surfaces the segment from the
// point o to light sample l crosses; l is visible iff D(l) = 0.
//
// Moving the segment's end from a reference sample r to l along the light, D changes only
// where the moving segment sweeps over a silhouette edge (§3.2): over an edge whose two
// triangles lie on the same side of the plane through o and the edge, by 2 (a closed mesh's
// silhouette: front and back surface), over a boundary edge by 1, over any other edge by 0
// (one triangle ends where the next begins). So
//   D(l) = D(r) + sum over edges the triangle (o, r, l) crosses of +-k_e,
// D(r) from one ray (§3.3), and k_e = sum over the edge's triangles of the side of their
// third vertex w (sign((a x b) . w), all relative to o). The edge a-b crosses the triangle
// (o, r, l) iff (the segment-triangle test) r and l lie on opposite sides of the plane (o, a, b),
// the line a-b passes on o's side of the line r-l, and a and b lie on opposite sides of the
// plane (o, r, l): four linear functions of l, so each edge costs four dot products per light
// sample and updates an integer counter per sample (§3.2's "integer counter per light
// sample, incremented or decremented according to the edge's orientation").
#pragma once

#include <cmath>
#include <cstdint>

#include "penumbra/core/math.h"
#include "penumbra/shadow/soft_shadow_volumes/silhouette_edges.h"
#include "penumbra/shadow/soft_shadow_volumes/ssv_shared.h"

namespace penumbra::ssv {

// The light samples relative to the point o (l_i - o), structure of arrays, each padded to
// padded_samples(count) floats with zeros (crossing_kernel.h); `depth` likewise.
struct SampleOffsets {
  const float* x;
  const float* y;
  const float* z;
  int count;
};

// The edge's k_e seen from o (0: not a silhouette from o: it changes nothing).
int edge_weight(const SilhouetteEdge& e, Vec3f o);

// The planes of a two-triangle edge's triangles, in float, for a quick test that an edge is
// surely no silhouette from o (o in front of one and behind the other, both by more than the
// rounding of the test): most edges a point's pyramid holds are not, and add_edge_crossings
// decides them in double.
struct EdgeFacing {
  Vec3f n[2];     // (b - a) x (w_t - a)
  float d[2];     // -n . a
  float scale[2]; // |n|, |d|: the size of the rounding
  bool two_sided = false;
};
EdgeFacing edge_facing(const SilhouetteEdge& e);
// True only where k_e(o) = 0 for certain; false where the edge may be a silhouette from o.
// o_size: max |coordinate| of o.
inline bool surely_not_silhouette(const EdgeFacing& f, Vec3f o, float o_size) {
  return f.two_sided && shader::ssv_surely_not_silhouette(f.n[0], f.d[0], f.scale[0], f.n[1], f.d[1], f.scale[1], o,
                                                          o_size);
}

// Adds the edge's change to depth[i] for every light sample i whose segment from o, swept
// from the reference sample r (r relative to o: r - o), crosses the edge. Returns false
// where the edge changes nothing from o (k_e = 0, or r on the edge's plane through o).
bool add_edge_crossings(const SilhouetteEdge& e, Vec3f o, Vec3f r, const SampleOffsets& samples, int32_t* depth);

}  // namespace penumbra::ssv
