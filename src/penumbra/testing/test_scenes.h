// Tiny scenes built in code for tests: quads, boxes and a rect light, with the camera
// looking down at the receiver. Header-only; used by *_test.cpp files only.
#pragma once

#include "penumbra/scene/scene.h"

namespace penumbra::testing {

// An axis-aligned quad at height y spanning [x0,x1] x [z0,z1], normal +y.
inline TriangleMesh quad_y(float y, float x0, float x1, float z0, float z1) {
  TriangleMesh m;
  m.positions = {{x0, y, z0}, {x1, y, z0}, {x1, y, z1}, {x0, y, z1}};
  // Counter-clockwise seen from +y.
  m.indices = {0, 2, 1, 0, 3, 2};
  return m;
}

// A closed axis-aligned box with outward-facing triangles.
inline TriangleMesh box(Vec3f lo, Vec3f hi) {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i)
    m.positions.push_back({(i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z});
  // Faces as (a, b, c, d) counter-clockwise seen from outside.
  const uint32_t faces[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (auto& f : faces) m.indices.insert(m.indices.end(), {f[0], f[1], f[2], f[0], f[2], f[3]});
  return m;
}

inline SceneObject object(TriangleMesh mesh, Vec3f albedo = Vec3f(0.8f), float opacity = 1.0f) {
  SceneObject o;
  o.name = "test";
  o.mesh = std::move(mesh);
  o.material.albedo = albedo;
  o.material.opacity = opacity;
  return o;
}

// A rect light of size w x h centred at `center`, facing down (-y).
inline AreaLight rect_light_down(Vec3f center, float w, float h, Vec3f radiance = Vec3f(1.0f)) {
  AreaLight l;
  l.shape = LightShape::Rect;
  l.center = center;
  l.frame = Frame::from_zx({0, -1, 0}, {1, 0, 0});
  l.size = {w, h};
  l.radiance = radiance;
  return l;
}

// An ellipsoid light centred at `center` with semi-axes radii (along x, z, -y: its frame.n
// points down at the ground, the axis light-space methods look along).
inline AreaLight ellipsoid_light_down(Vec3f center, Vec3f radii, Vec3f radiance = Vec3f(1.0f)) {
  AreaLight l;
  l.shape = LightShape::Ellipsoid;
  l.center = center;
  l.frame = Frame::from_zx({0, -1, 0}, {1, 0, 0});
  l.radii = radii;
  l.radiance = radiance;
  return l;
}

// A camera straight above the origin looking down at the ground (image x = world x,
// image rows = world +z going down the image).
inline Camera top_camera(int res, float height = 4.0f, float fov = 60.0f) {
  Camera c;
  c.eye = {0, height, 0};
  c.target = {0, 0, 0};
  c.up = {0, 0, -1};
  c.fov_y = fov;
  c.width = c.height = res;
  return c;
}

// Ground quad (y = 0, 8 x 8) under a rect light at height 2, plus the given occluders.
inline Scene ground_scene(std::vector<SceneObject> occluders, AreaLight light, int res = 32) {
  Scene s;
  s.camera = top_camera(res);
  s.lights.push_back(light);
  s.objects.push_back(object(quad_y(0, -4, 4, -4, 4)));
  for (auto& o : occluders) s.objects.push_back(std::move(o));
  s.finalize();
  return s;
}

}  // namespace penumbra::testing
