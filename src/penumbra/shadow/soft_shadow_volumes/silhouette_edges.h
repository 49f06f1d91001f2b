// The potential silhouette edges of a scene's casters with respect to a whole area light
// (Laine et al. 2005 §3.1): the edges whose adjacent triangles can face a point of the light
// differently, plus every boundary edge of an open mesh (§3.4: an open surface's border
// changes the depth complexity by one wherever it is seen).
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/scene/scene.h"

namespace penumbra::ssv {

// One edge a-b and the third vertices of up to two of its triangles (an edge with more is
// split into several entries: their contributions add up, depth_complexity.h).
struct SilhouetteEdge {
  Vec3f a, b;
  Vec3f w[2];
  uint32_t triangles = 0;  // 1 (a boundary edge, or one part of a non-manifold edge) or 2
};

// The region of space the light's samples lie in: "the whole light" of the silhouette test.
// Planar: the rectangle [-half.x, half.x] x [-half.y, half.y] around `center` in the plane
// spanned by s and t (a rect itself; the square around a disk or a sphere's disk: every sample
// lies there, light_samples.h); otherwise the ball of `radius` around the centre
// (conservative for any shape).
struct LightRegion {
  Vec3f center;
  float radius = 0;
  bool planar = false;
  Vec3f s, t;
  Vec2f half{0, 0};
  // A one-sided light (rect, disk) emits along n only: what lies on or behind its plane blocks
  // none of it, and the casters are clipped to the part in front (potential_silhouettes).
  bool one_sided = false;
  Vec3f n{0, 0, 0};
};
// The region of a light: planar for rect, disk and sphere, the ball of its extent radius for
// an ellipsoid.
LightRegion light_region(const AreaLight& light);

// Whether a triangle of this opacity (the material's times the mesh's per-triangle one) and
// material stops only part of the light somewhere: semi-transparent, or alpha-textured (a
// mask's holes are not bounded by its edges). ssv-rt tests such casters per light sample; they
// have no silhouette edges here.
inline bool stops_part_of_the_light(float opacity, const Material& material) {
  return material.alpha_textured() || !(opacity >= 1.0f);
}

// For a one-sided light the casters are first clipped to the part in front of its plane, cut just
// in front of it (the light centre's ray offset, trace/ray_shared.h on_or_behind_light_plane): a
// triangle wholly on or behind the plane (a ceiling flush with the light) has no edge here, and a
// surface through the light (a wall across it) ends there in boundary edges (§3.4). §3.2's sweep
// changes D only where the segment's end crosses an edge, so a surface that met the light itself
// would change D along a line of the light that is no edge. A cut point is computed from the
// edge's welded ends in one order, so the two triangles of an edge cut it at the same point.
//
// Edges are welded by position (bitwise equal vertices count as one, so meshes stored with
// split vertices at seams and creases do not turn every crease into two boundary edges).
// An edge with two triangles is kept when one of their planes cuts the region (some light
// point sees one side, another the other) or, where neither does, when both triangles lie on
// one side of the plane through the region's centre and the edge (the whole light sees a
// silhouette). Triangles of zero opacity cast nothing, those that stop only part of the
// light are tested otherwise (stops_part_of_the_light): both are left out.
std::vector<SilhouetteEdge> potential_silhouettes(const Scene& scene, const LightRegion& light);

// For memory estimates: a closed mesh has 3/2 edges per triangle (a triangle soup stored
// without shared vertices up to 3: twice the estimate); what potential_silhouettes holds per
// edge while it works (the welded vertices' map nodes and the mesh vertices' welded ids, the
// two 16-byte sides of an edge), and what its result holds (each object's edges grown by
// doubling, then all of them joined in one array).
inline constexpr double kEdgesPerTriangle = 1.5;
inline constexpr uint64_t kSilhouetteBuildBytesPerEdge = 40 + 4 + 2 * 16;
inline constexpr uint64_t kSilhouetteResultBytesPerEdge = 3 * sizeof(SilhouetteEdge);

}  // namespace penumbra::ssv
