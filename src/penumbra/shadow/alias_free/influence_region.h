// A triangle's influence region (sintorn2008 §4.1): the part of the light's image where a
// view sample can lie if the triangle blocks some point of the light from it.
//
// On a far plane (linear depth F from the light's centre, beyond every listed view sample)
// it is contained in the convex hull of the light's bounding polygon projected through each
// vertex: a point f on the far plane is shadowed from light point q by triangle point x when
// q, x, f are collinear; f depends affinely on q for fixed x and projectively on x for fixed
// q, so f lies in the hull of the 3 x (polygon vertices) projections. Every view sample in
// front of the far plane that the triangle shadows projects (from the light's centre) into
// the hull of the triangle's own projection and that region, and the triangle's projection
// from the centre is itself inside the region (the centre is a point of the light).
// The light's bounding polygon: the rect's corners; the disk's circumscribed 8-gon; for a
// sphere, per vertex, the regular hexagon around the silhouette circle seen from that vertex
// (sintorn2008 §4.1), which bounds every point of the ball; for an ellipsoid, the same
// hexagon in the space scaled to the unit sphere, mapped back (§4.1, AreaLight's map A).
#pragma once

#include <array>
#include <span>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/raster/light_view.h"
#include "penumbra/scene/light.h"

namespace penumbra::afsm {

// Andrew's monotone chain: the convex hull of `points`, counter-clockwise (y up) without
// collinear points; in place.
void convex_hull(std::vector<Vec2f>* points);

class InfluenceRegions {
 public:
  // view: the light's image (eye at the light's centre, looking along frame.n);
  // far_depth: linear depth of the far plane (>= every listed view sample).
  InfluenceRegions(const AreaLight& light, const LightView& view, float far_depth);
  // The region of triangle v[3] as a convex polygon in texel space (appended to *out after
  // clearing it). False when the region is unbounded (a vertex too close to, or behind, the
  // light's points): the caller must treat the whole image as covered.
  bool region(const Vec3f v[3], std::vector<Vec2f>* out) const { return region(std::span<const Vec3f>(v, 3), out); }
  // The same for any set of points (pass a span: an array would decay to the triangle's three): the hull of the light's polygon projected through each.
  // It holds the region of every triangle inside the points' convex hull (for a fixed light
  // point the projection through x is a central projection, which keeps convex hulls), so
  // the 8 corners of a group of casters' bounding box bound the whole group's regions.
  bool region(std::span<const Vec3f> points, std::vector<Vec2f>* out) const {
    if (!project(points, out)) return false;
    convex_hull(out);
    return true;
  }
  // The points region() takes the hull of, unordered: enough for the region's bounding box,
  // which is all a caller that only tests for overlap needs (the hull is most of the cost).
  bool project(std::span<const Vec3f> points, std::vector<Vec2f>* out) const;

 private:
  const AreaLight& light_;
  const LightView& view_;
  float far_;
  std::vector<Vec3f> outline_;  // rect / disk: the bounding polygon (world)
  // Per outline point q: the view's texel projection of q, homogeneous (x, y, w), and q's
  // depth along the view axis. A point f = q + (v - q) t of the segment through v projects to
  // (H(q) + (H(v) - H(q)) t) over its w alike (H is affine): one transform per vertex, not
  // one per vertex and outline point.
  std::vector<std::array<float, 4>> outline_texel_;
};

// The vertices region() usually gives for this light (null: any light), for memory
// estimates: the region is the hull of the light's bounding polygon (rect 4, disk 8, sphere
// and ellipsoid 6 vertices) projected through each of the three vertices, which has the
// polygon's vertices and about three more (bridges between the projections); at most three
// times the polygon's.
int typical_region_vertices(const AreaLight* light);


}  // namespace penumbra::afsm
