// The "outer objects" of parker1998: an occluder's opacity falls off from its real surface
// outward over a width that grows linearly with the distance from the shading point, so a
// single shadow ray toward the light's centre yields a soft shadow.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/scene/mesh.h"
#include "penumbra/shadow/single_sample/single_sample_shared.h"

namespace penumbra::single_sample {

// parker1998 appendix: the falloff s(tau) (0 at the inner surface, 1 at the outer object's
// boundary), its inverse, and a sphere (centre c, radius R) against a shadow ray o + t v (unit v)
// toward a light of diameter D at distance light_dist: single_sample_shared.h, which the GPU runs
// too.
inline float falloff(float tau) { return shader::ss_falloff(tau); }
inline float inverse_falloff(float s) { return shader::ss_inverse_falloff(s); }
inline float sphere_transmission(Vec3f o, Vec3f v, float light_dist, Vec3f c, float R, float D) {
  return shader::ss_sphere_transmission(o, v, light_dist, c, R, D);
}

// The triangle's outer object generalised so that it is exact for every ray: a point x
// of the occluder at distance t along the ray and `perp` from it has tau = perp / b(t)
// with b(t) = D t / light_dist, i.e. tau = (perp / t) * light_dist / D. perp / t is the
// distance from the ray's axis in a perspective projection centred on o, so the smallest
// tau over the triangle is the 2D distance from the axis to the projected triangle
// (clipped to near <= t <= far). In parker1998's terms: the triangle grown per edge by the
// offset b with rounded corners (Fig. 6b), the offset measured perpendicular to the ray.
// Returns +inf when no part of the triangle lies in [near, far] along the ray.
// (e1, e2, v) is an orthonormal frame around the ray.
float triangle_cone_distance(Vec3f o, Vec3f v, Vec3f e1, Vec3f e2, float near, float far, Vec3f a, Vec3f b,
                             Vec3f c);

// The squared version of triangle_cone_distance, without the final sqrt, for the search's
// inner loop (it compares against a squared limit): single_sample_shared.h
// ss_triangle_cone_distance2.
float triangle_cone_distance2(Vec3f o, Vec3f v, Vec3f e1, Vec3f e2, float near, float far, Vec3f a, Vec3f b,
                              Vec3f c);

// Four triangles side by side (structure of arrays) for triangle_cone_distance2 on four
// lanes at once: v[vertex][axis][lane]. Unused lanes repeat a used one.
struct TriangleBlock4 {
  alignas(16) float v[3][3][4];
  void set(int lane, Vec3f a, Vec3f b, Vec3f c);
  Vec3f vertex(int lane, int k) const { return {v[k][0][lane], v[k][1][lane], v[k][2][lane]}; }
};
// triangle_cone_distance2 of the block's four triangles into out[4] (SIMD; lanes with a
// vertex outside [near, far] along the ray take the clipping path one by one).
void block_cone_distance2(const TriangleBlock4& block, Vec3f o, Vec3f v, Vec3f e1, Vec3f e2, float near, float far,
                          float out[4]);
// The same for the lanes whose triangle lies within [near, far] along the ray; returns the
// bit mask of the other lanes (out[] meaningless there), for the caller to clip.
int block_cone_distance2_unclipped(const TriangleBlock4& block, Vec3f o, Vec3f v, Vec3f e1, Vec3f e2, float near,
                                   float far, float out[4]);

// The connectivity of a mesh with its vertices welded by exact position (shading seams
// and importers split vertices without opening the surface).
struct MeshTopology {
  std::vector<uint32_t> canon;    // welded vertex id of each mesh vertex
  std::vector<uint32_t> corners;  // welded vertex id of each triangle corner (3 per triangle)
  // Triangles around each welded vertex: vertex_tris[vertex_first[v] .. vertex_first[v + 1]).
  std::vector<uint32_t> vertex_first, vertex_tris;
};
MeshTopology build_topology(const TriangleMesh& mesh);
// For memory estimates: a mesh's topology, and the most building it and its contour
// (contour_triangles) hold besides: the weld table, the welded positions, the edges.
uint64_t contour_bytes(uint64_t triangles, uint64_t vertices);

// Candidate occluders of a closed opaque surface for shadow rays toward the point light_pos.
// For a ray that misses a closed surface, the point of the surface nearest to the ray in
// cone space (smallest perp / t) lies on the surface's contour as seen from the ray's
// origin o (the boundary of its projection from o; nothing inside the projection is
// nearer to an axis outside it). The ray ends at light_pos and the contour point lies
// near the line o-l, so the contour seen from o is nearly the contour seen from l: they
// coincide where the ray grazes the edge (tau = 0) and part as tau grows (the
// approximation, docs/methods/single-sample.md). Marks the triangles adjacent to an edge
// that is a contour edge seen from light_pos (the two neighbouring triangles fold to the
// same side of the plane through the edge and light_pos), a boundary edge (one triangle)
// or a non-manifold edge (three or more).
//
// Exactness: a point x on the contour seen from o with tau < 1 is also on the contour
// seen from the point q where the line o-x reaches the light's distance, and |q - l| =
// tau D < D. An edge whose contour status differs between l and q has a triangle whose
// plane separates l from q, i.e. passes within D of l. So with band_radius = D the set
// also holds every triangle whose plane passes within band_radius of light_pos, and the
// minimum over the set equals the minimum over the whole closed mesh for every ray that
// misses it.
std::vector<uint8_t> contour_triangles(const TriangleMesh& mesh, const MeshTopology& topo, Vec3f light_pos,
                                       float band_radius = 0.0f);
inline std::vector<uint8_t> contour_triangles(const TriangleMesh& mesh, Vec3f light_pos, float band_radius = 0.0f) {
  return contour_triangles(mesh, build_topology(mesh), light_pos, band_radius);
}

}  // namespace penumbra::single_sample
