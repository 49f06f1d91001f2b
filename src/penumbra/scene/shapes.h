// Tessellated primitive shapes shared by the scene loader ("shape": plane/box/sphere) and
// the procedural generators (tubes for stems and knots, spheres for the furball). All
// have outward, counter-clockwise windings and vertex normals, so any of them can be
// appended to another without losing normals (TriangleMesh::append).
#pragma once

#include <span>

#include "penumbra/scene/mesh.h"

namespace penumbra {

// A w x d rectangle in the xz-plane centred at the origin, normal +y. Open (not closed).
// Texture coordinates span it: u along +x, v = 1 at -z (the image as seen from above).
TriangleMesh make_plane(Vec2f size);

// An axis-aligned box centred at the origin with full edge lengths `size`. Closed; 24
// vertices (flat faces: each corner has one copy per face so the normals stay sharp); each
// face carries the whole texture ([0,1]^2).
TriangleMesh make_box(Vec3f size);

// A closed UV sphere centred at the origin: `segments` slices around the y axis and
// segments / 2 (at least 2) stacks from pole to pole, one vertex per pole.
TriangleMesh make_uv_sphere(float radius, int segments);

// A tube of `sides` sides around the polyline `centre` with radius radii[i] at point i
// (one radius for all if radii has one element). `loop` joins the last ring to the first
// (a closed curve, e.g. a torus knot); otherwise `caps` closes both ends with flat disks.
// Rings follow rotation-minimizing frames (double reflection, Wang et al. 2008,
// "Computation of rotation minimizing frames"), so thin tubes do not twist; for loops the
// frame's holonomy is spread evenly along the curve so the last ring meets the first.
// Consecutive duplicate points are skipped. Closed when `loop` or `caps`.
TriangleMesh make_tube(std::span<const Vec3f> centre, std::span<const float> radii, int sides,
                       bool loop, bool caps);

// Signed volume enclosed by a mesh (divergence theorem); positive for closed meshes with
// outward windings. Useful for checks.
double signed_volume(const TriangleMesh& mesh);

}  // namespace penumbra
