#include "penumbra/shadow/single_sample/occluders.h"

#include <algorithm>
#include <cmath>

#include "penumbra/core/parallel.h"
#include "penumbra/trace/ray_shared.h"

namespace penumbra::single_sample {

OccluderSettings occluder_settings(const ParamSet& p) {
  OccluderSettings s;
  s.equal_area = p.get_string("diameter") == "equal-area";
  s.diameter_scale = p.get_float("diameter_scale");
  s.contour_only = p.get_string("candidates") != "all";
  s.band = p.get_float("band");
  s.ring = p.get_bool("neighbours");
  s.leaf_size = p.get_int("leaf_size");
  return s;
}

Plane triangle_plane(const BvhTriangle& t) {
  Vec3f n = cross(t.v1 - t.v0, t.v2 - t.v0);
  float len = length(n);
  if (!(len > 0)) return {Vec3f(0.0f), kInfinity};
  n = n / len;
  return {n, dot(n, t.v0)};
}

Occluders build_occluders(const Scene& scene, const AreaLight& l, const OccluderSettings& settings) {
  Occluders occ;
  // parker1998 uses the light's diameter D. A rect has none: its diagonal over-states
  // the penumbra, the diameter of the disk of equal area matches its mean width.
  // An ellipsoid, likewise: the disk of its central ellipse's area, or its longest axis.
  const bool elongated = l.shape == LightShape::Rect || l.shape == LightShape::Ellipsoid;
  occ.diameter = (elongated && settings.equal_area) ? 2.0f * std::sqrt(l.area() / kPi) : l.diameter();
  occ.diameter *= settings.diameter_scale;
  // The search runs in a frame centred on the light with z toward the scene: every
  // shadow ray ends at its origin and runs roughly along -z, and the contour triangles
  // lie edge-on to the light, so boxes aligned with this frame are thin across the rays
  // (world-axis boxes of the same slivers are not).
  const Bounds3f scene_bounds = scene.bounds();
  Vec3f toward = scene_bounds.center() - l.center;
  occ.light_frame = length_squared(toward) > 0 ? Frame::from_z(toward) : Frame::from_z(-l.frame.n);
  occ.light_pos = l.center;
  {
    // Planes and receivers are compared in the light frame, where lengths are at the scale of
    // the scene's reach from the light; the receivers came from world coordinates, exact to
    // their ulps. So the tolerance is 1e-4 of the reach plus the ray offset's share of the
    // largest coordinate (trace/ray_shared.h): a scene 2 x 10^4 units from the origin keeps a
    // plate 0.04 over its ground apart from it, and one modelled 1/1000 of its size its contacts.
    const Bounds3f& b = scene_bounds;
    float reach = 0;
    for (int c = 0; c < 8; ++c)
      reach = std::max(reach, length(Vec3f(c & 1 ? b.hi.x : b.lo.x, c & 2 ? b.hi.y : b.lo.y, c & 4 ? b.hi.z : b.lo.z) - l.center));
    const float largest = std::max(max_component(vmax(b.hi, -b.hi)), max_component(vmax(b.lo, -b.lo)));
    occ.scene_scale = reach;
    occ.plane_eps = 1e-4f * reach + shader::kRayOffsetRelative * largest;
  }
  // A planar light's occluders lie in front of its plane: a triangle wholly on or behind it (a
  // ceiling flush with the light, its fixture) blocks none of its light, though its outer object,
  // b(t) wide at the light, would cover the whole light for every oblique ray
  // (trace/ray_shared.h on_or_behind_light_plane).
  const bool planar = l.shape == LightShape::Rect || l.shape == LightShape::Disk;
  auto behind_the_light = [&](const TriangleMesh& m, size_t t) {
    if (!planar) return false;
    for (int k = 0; k < 3; ++k) {
      const Vec3f p = m.vertex(t, k);
      if (!shader::on_or_behind_light_plane(dot(p - l.center, l.frame.n), p)) return false;
    }
    return true;
  };
  std::vector<BvhTriangle> tris;
  size_t all_count = 0;
  occ.objects.assign(scene.objects.size(), {});
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& obj = scene.objects[o];
    if (obj.sphere) continue;  // parker1998's analytic sphere instead
    const TriangleMesh& m = obj.mesh;
    const size_t count = m.triangle_count();
    all_count += count;
    // An alpha texture (issue 20) counts as its mean over each triangle: the cone query
    // measures distances to whole triangles, not to a mask's edges (docs/methods/single-sample.md).
    const bool textured = obj.material.alpha_textured() && m.uvs.size() == m.positions.size();
    auto opacity = [&](size_t t) {
      float a = obj.material.opacity * (m.triangle_opacity.empty() ? 1.0f : m.triangle_opacity[t]);
      if (textured) {
        const Vec2f uv[3] = {m.uvs[m.indices[3 * t]], m.uvs[m.indices[3 * t + 1]], m.uvs[m.indices[3 * t + 2]]};
        a *= obj.material.alpha.mean_opacity(uv);
      }
      return a;
    };
    bool opaque = true;
    for (size_t t = 0; t < count && opaque; ++t) opaque = opacity(t) >= 1.0f;
    // With `contour`, only the triangles along an opaque mesh's contour seen from the
    // light centre (outer_objects.h: the nearest point in cone space of a surface the
    // ray misses lies on that contour). Semi-transparent objects keep every triangle: a
    // ray may cross them and still see the light.
    std::vector<uint8_t> keep;
    if (settings.contour_only && opaque) {
      ObjectData& od = occ.objects[o];
      od.topology = single_sample::build_topology(m);
      od.ring = settings.ring;
      keep = single_sample::contour_triangles(m, od.topology, l.center, settings.band * occ.diameter);
      if (settings.ring) {
        // Planes in the light frame, from the welded vertices transformed once each.
        const auto& topo = od.topology;
        std::vector<Vec3f> pos(topo.vertex_first.size() - 1);
        for (size_t i = 0; i < m.positions.size(); ++i) pos[topo.canon[i]] = occ.to_light_space(m.positions[i]);
        od.planes.resize(count);
        parallel_for(count, 4096, [&](size_t b, size_t e) {
          for (size_t t = b; t < e; ++t)
            od.planes[t] = triangle_plane(
                BvhTriangle{pos[topo.corners[3 * t]], pos[topo.corners[3 * t + 1]], pos[topo.corners[3 * t + 2]]});
        });
        // The same planes in the order of the vertex fans, read contiguously by gather_ring.
        od.fan_planes.resize(od.topology.vertex_tris.size());
        parallel_for(od.fan_planes.size(), 16384, [&](size_t b, size_t e) {
          for (size_t i = b; i < e; ++i) od.fan_planes[i] = od.planes[od.topology.vertex_tris[i]];
        });
        // A flat object (a ground plane): every neighbour lies in the receiver's plane
        // and is excluded anyway.
        bool flat = true;
        for (size_t t = 1; t < count && flat; ++t)
          flat = dot(od.planes[t].n, od.planes[0].n) > 1 - 1e-6f && std::abs(od.planes[t].d - od.planes[0].d) < occ.plane_eps;
        od.ring = !flat;
      }
    }
    for (size_t t = 0; t < count; ++t)
      if ((keep.empty() || keep[t]) && !behind_the_light(m, t))
        tris.push_back({occ.to_light_space(m.vertex(t, 0)), occ.to_light_space(m.vertex(t, 1)),
                        occ.to_light_space(m.vertex(t, 2)), static_cast<uint32_t>(o), static_cast<uint32_t>(t),
                        opacity(t)});
  }
  occ.all_triangles = all_count;
  occ.bvh = TriangleBvh(std::move(tris), settings.leaf_size);
  for (const BvhTriangle& t : occ.bvh.triangles()) occ.planes.push_back(triangle_plane(t));
  for (size_t o = 0; o < scene.objects.size(); ++o)
    if (scene.objects[o].sphere)
      occ.spheres.push_back({*scene.objects[o].sphere, static_cast<uint32_t>(o), scene.objects[o].material.opacity});
  return occ;
}

}  // namespace penumbra::single_sample
