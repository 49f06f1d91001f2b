// Tiny scenes built in code for tests: quads, boxes and a rect light, with the camera
// looking down at the receiver. Header-only; used by *_test.cpp files only.
#pragma once

#include <cstring>
#include <memory>
#include <vector>

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

// One light of each shape around `center` (a rect, a disk, a sphere and an ellipsoid, all facing
// down), about a unit across: for tests that must hold for every light shape.
inline std::vector<AreaLight> every_light_shape(Vec3f center) {
  AreaLight rect = rect_light_down(center, 1.2f, 0.7f);
  AreaLight disk = rect;
  disk.shape = LightShape::Disk;
  disk.radius = 0.5f;
  AreaLight sphere = rect;
  sphere.shape = LightShape::Sphere;
  sphere.radius = 0.4f;
  return {rect, disk, sphere, ellipsoid_light_down(center, {0.6f, 0.3f, 0.2f})};
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

// A box and two open plates on an 8 x 8 ground under a tilted rect light, seen at a slant, every
// length times `scale`, the whole moved by `offset`: one plate 0.04 above the ground (a contact a
// world-unit bias swallows at small scales), one 0.5 above it. At scale 10^5 the light is 3 x 10^5
// units from the ground, where a float depth is exact to 0.03; at an offset of 2 x 10^4 (a
// georeferenced model) a float coordinate is exact to 0.002, though every distance is unit-sized.
// The scene units test (render/scene_units_test.cpp).
inline Scene contact_scene_at_scale(float scale, int res = 40, Vec3f offset = {0, 0, 0}) {
  const float k = scale;
  Scene s;
  s.camera.eye = Vec3f(0.6f, 3.2f, 4.0f) * k + offset;
  s.camera.target = Vec3f(0.2f, 0.2f, 0.0f) * k + offset;
  s.camera.up = {0, 1, 0};
  s.camera.fov_y = 50;
  s.camera.width = s.camera.height = res;
  AreaLight light = rect_light_down(Vec3f(-0.6f, 3.0f, 0.4f) * k + offset, 1.2f * k, 0.8f * k);
  light.frame = Frame::from_zx(normalize(Vec3f(0.2f, -1.0f, -0.1f)), {1, 0, 0});
  s.lights.push_back(light);
  const Vec3f o = offset;
  s.objects.push_back(object(quad_y(o.y, o.x - 4 * k, o.x + 4 * k, o.z - 4 * k, o.z + 4 * k)));
  s.objects.push_back(object(box(Vec3f(-0.6f, 0.0f, -0.5f) * k + o, Vec3f(0.2f, 0.7f, 0.3f) * k + o)));
  s.objects.push_back(object(quad_y(o.y + 0.04f * k, o.x + 0.7f * k, o.x + 1.5f * k, o.z - 0.3f * k, o.z + 0.5f * k)));
  s.objects.push_back(object(quad_y(o.y + 0.5f * k, o.x - 0.4f * k, o.x + 0.4f * k, o.z + 0.8f * k, o.z + 1.4f * k)));
  s.finalize();
  return s;
}
// A ledge beside a light that faces down at height 2: a plate 0.001 in front of the light's plane
// (1.999, x from 0.7 to 2), lit at grazing angles over a wall (x = 0.6, up to 1.9996) that hides
// part of the light from it, and a box on the ground. The plate's points lie 89.8 degrees and
// more off the light's axis: no light view capped at max_fov (179 degrees) holds them, as the
// ceiling beside a window that a light outside shines through (alias_free_test.cpp).
inline Scene ledge_beside_the_light_scene(int res = 48) {
  TriangleMesh wall;
  wall.positions = {{0.6f, 1.5f, -1.0f}, {0.6f, 1.5f, 1.0f}, {0.6f, 1.9996f, 1.0f}, {0.6f, 1.9996f, -1.0f}};
  wall.indices = {0, 1, 2, 0, 2, 3};
  return ground_scene({object(quad_y(1.999f, 0.7f, 2.0f, -1.0f, 1.0f)), object(std::move(wall)),
                       object(box({-0.3f, 0, -0.2f}, {0.2f, 0.5f, 0.3f}))},
                      rect_light_down({0, 2, 0}, 1.0f, 0.6f), res);
}

// `scene` with a ceiling in its first light's plane: a square 2 half_size across around the light,
// facing where the light faces, `gap` behind the light's plane (0: flush with it, a panel light
// set into its ceiling). Nothing there can block any of the light for a point in front of it
// (trace/ray_shared.h on_or_behind_light_plane), so every method's V is the scene's own
// (render/scene_units_test.cpp, gpu_renderer_test.cpp).
inline Scene with_a_ceiling_at_the_light(Scene scene, float gap, float half_size) {
  const AreaLight& l = scene.lights.at(0);
  const Vec3f c = l.center - l.frame.n * gap, s = l.frame.s * half_size, t = l.frame.t * half_size;
  TriangleMesh m;
  m.positions = {c - s - t, c + s - t, c + s + t, c - s + t};
  // Counter-clockwise seen from the side the light faces (its normal along frame.n).
  m.indices = dot(cross(s, t), l.frame.n) > 0 ? std::vector<uint32_t>{0, 1, 2, 0, 2, 3} : std::vector<uint32_t>{0, 2, 1, 0, 3, 2};
  scene.objects.push_back(object(std::move(m)));
  scene.finalize();
  return scene;
}

// A 1 x 1 light 2.5 over ground_scene's ground, facing down, with a lamp's two shades hanging
// beside it (1.3 x 0.3 x 0.05, 0.13 off its edges, their tops in its plane) and a box under it: casters so near the light and so far off its axis that views from points of the light capped
// at 76 degrees cannot hold them (ShadowRegion::light_field; coherent_rt_test.cpp,
// coherent_rt_gpu_test.cpp).
inline Scene lamp_shades_scene(int res) {
  Scene s = ground_scene({object(box({-0.63f, 2.2f, 0.605f}, {0.67f, 2.5f, 0.655f})),
                          object(box({-0.67f, 2.2f, -0.655f}, {0.63f, 2.5f, -0.605f})),
                          object(box({-0.2f, 0.0f, -0.2f}, {0.2f, 0.9f, 0.2f}))},
                         rect_light_down({0.0f, 2.5f, 0.0f}, 1.0f, 1.0f), res);
  s.camera.eye = {0.6f, 1.3f, 2.6f};
  s.camera.target = {0.1f, 0.35f, 0.0f};
  s.camera.up = {0, 1, 0};
  s.camera.fov_y = 40;
  s.finalize();
  return s;
}

// A bulb in a closed room (docs/data/scenes/bulb-room.json): a sphere light of radius 0.15 at
// 1.6 in a 6 x 3 x 6 room of six slabs, a shelf 0.7 above the bulb and a table under it, seen
// from a corner so that the floor, two walls and the ceiling are in view. The bulb's frame.n
// points down (toward the room's centre): a light-space method's one disk facing it leaves the
// walls' upper half and the ceiling behind its plane (split_sphere_lights; scene_units_test.cpp,
// gpu_renderer_test.cpp).
inline Scene bulb_in_a_room_scene(int res) {
  Scene s;
  const auto slab = [&](Vec3f lo, Vec3f hi) { s.objects.push_back(object(box(lo, hi))); };
  slab({-3.0f, -0.1f, -3.0f}, {3.0f, 0.0f, 3.0f});  // floor
  slab({-3.0f, 3.0f, -3.0f}, {3.0f, 3.1f, 3.0f});   // ceiling
  slab({-3.0f, 0.0f, -3.1f}, {3.0f, 3.0f, -3.0f});
  slab({-3.0f, 0.0f, 3.0f}, {3.0f, 3.0f, 3.1f});
  slab({-3.1f, 0.0f, -3.0f}, {-3.0f, 3.0f, 3.0f});
  slab({3.0f, 0.0f, -3.0f}, {3.1f, 3.0f, 3.0f});
  slab({-0.2f, 2.275f, 0.0f}, {0.8f, 2.325f, 0.4f});   // the shelf
  slab({-0.1f, 0.725f, 0.1f}, {1.1f, 0.775f, 0.9f});   // the table
  AreaLight bulb;
  bulb.shape = LightShape::Sphere;
  bulb.center = {0.3f, 1.6f, 0.2f};
  bulb.radius = 0.15f;
  bulb.radiance = Vec3f(30.0f);
  s.lights.push_back(bulb);
  s.camera.eye = {-2.5f, 1.5f, -2.5f};
  s.camera.target = {1.0f, 1.2f, 1.0f};
  s.camera.up = {0, 1, 0};
  s.camera.fov_y = 70;
  s.camera.width = s.camera.height = res;
  s.finalize();
  return s;
}

// bulb_in_a_room_scene with its ceiling 4 lower (under the floor) and its walls and shelf 3
// lower: nothing reaches behind the bulb's disk, so the bulb is one light; the same triangles,
// so Renderer::set_objects can move them back up around it (renderer_test.cpp,
// gpu_renderer_test.cpp). Indices of the moved objects: 1-6.
inline Scene bulb_room_lowered_scene(int res) {
  Scene s = bulb_in_a_room_scene(res);
  for (uint32_t o = 1; o <= 6; ++o) {
    ObjectTransform t;
    t.translate = {0, o == 1 ? -4.0f : -3.0f, 0};
    place_object(s.objects[o], t);
  }
  s.finalize();
  return s;
}

// A street 400 units long and 2 wide with a box every 10 units and a block 8 wide and 10 tall at its middle,
// under a 3 x 3 light 30 above it, seen from one end: most of what the camera sees lies 70-85
// degrees off the light's axis, beyond the 60 degrees of a fitted map's max_fov and the 76 lam's
// shadow region is cut at, while the block far down the street lies inside both
// (baselines_test.cpp, lam_test.cpp, lam_gpu_test.cpp, gpu_renderer_test.cpp).
inline Scene street_beyond_the_cap_scene(int res = 48) {
  Scene s;
  s.camera.eye = {-200, 2, 0};
  s.camera.target = {0, 0, 0};
  s.camera.up = {0, 1, 0};
  s.camera.fov_y = 30;
  s.camera.width = s.camera.height = res;
  AreaLight light = rect_light_down({0, 30, 3}, 3, 3);
  light.frame = Frame::from_zx(normalize(Vec3f(0, -1, -0.1f)), {1, 0, 0});
  s.lights.push_back(light);
  s.objects.push_back(object(quad_y(0, -200, 200, -1, 1)));
  for (int x = -190; x <= 190; x += 10)
    s.objects.push_back(object(box(Vec3f(x - 0.25f, 0, -0.25f), Vec3f(x + 0.25f, 1, 0.25f))));
  s.objects.push_back(object(box(Vec3f(-3, 0, -4), Vec3f(3, 10, 4))));
  s.finalize();
  return s;
}

// The largest mean |dV| between contact_scene_at_scale(1) and another scale that still counts as
// the same picture (float rounding moves a few texels' decisions).
inline constexpr double kSceneUnitsTolerance = 0.003;

// Every vertex of the scene's meshes in front of `light`'s emitting side: receivers to fit a view
// of the whole scene to.
inline std::vector<Vec3f> vertices_in_front_of(const Scene& scene, const AreaLight& light) {
  std::vector<Vec3f> out;
  for (const SceneObject& o : scene.objects)
    for (Vec3f p : o.mesh.positions)
      if (dot(p - light.center, light.frame.n) > 0) out.push_back(p);
  return out;
}

// A placement for the i-th of several copies of a mesh, on a 5 x 5 grid 1.4 apart at heights
// 0.6-1.1 over the ground: turned, scaled, every seventh mirrored, every seventh (another)
// stretched along x.
inline ObjectTransform grid_placement(int i) {
  ObjectTransform t;
  t.translate = {(i % 5 - 2) * 1.4f, 0.6f + 0.1f * (i % 6), (i / 5 % 5 - 2) * 1.4f};
  t.rotate = {11.0f * i, 29.0f * i, 5.0f * i};
  t.scale = i % 7 == 3 ? Vec3f(-0.9f, 0.9f, 0.9f) : i % 7 == 5 ? Vec3f(1.4f, 0.6f, 1.0f) : Vec3f(0.7f + 0.02f * i);
  return t;
}

// The ground of ground_scene under `light`, and `copies` objects placing one shared mesh
// (SceneObject::shared_mesh) at grid_placement(0), (1), ...
inline Scene instanced_scene(const std::shared_ptr<const TriangleMesh>& mesh, int copies, AreaLight light,
                             int res = 32) {
  std::vector<SceneObject> occluders;
  for (int i = 0; i < copies; ++i) {
    SceneObject o = object(TriangleMesh{}, Vec3f(0.3f + 0.02f * i, 0.6f, 0.5f));
    o.shared_mesh = mesh;
    place_object(o, grid_placement(i));
    occluders.push_back(std::move(o));
  }
  return ground_scene(std::move(occluders), light, res);
}

// `s` with every object a mesh of its own (what the loader built before meshes were shared).
inline Scene unshared(Scene s) {
  for (SceneObject& o : s.objects) o.unshare();
  return s;
}

// A scene document with a camera, a rect light and a 20 x 20 ground (objects[0]), for tests that
// add objects to it.
inline nlohmann::json ground_scene_doc() {
  return nlohmann::json::parse(R"({
    "camera": {"eye": [0, 6, 9], "target": [0, 0, 0], "resolution": [32, 32]},
    "lights": [{"type": "rect", "center": [0, 8, 0], "normal": [0, -1, 0], "size": [2, 2]}],
    "objects": [{"shape": "plane", "size": [20, 20]}]
  })");
}

// An object transform as a scene file writes it.
inline nlohmann::json transform_json(const ObjectTransform& t) {
  auto v = [](Vec3f a) { return nlohmann::json::array({a.x, a.y, a.z}); };
  return {{"translate", v(t.translate)}, {"rotate", v(t.rotate)}, {"scale", v(t.scale)}};
}

// Bit-for-bit equality of arrays and meshes.
template <typename T>
inline bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

inline bool same_bits(const TriangleMesh& a, const TriangleMesh& b) {
  return same_bits(a.positions, b.positions) && same_bits(a.normals, b.normals) && same_bits(a.indices, b.indices) &&
         same_bits(a.uvs, b.uvs) && same_bits(a.triangle_opacity, b.triangle_opacity);
}

// SceneObject's invariant: the world mesh is the shared mesh transformed by the placement.
inline bool placed_exactly(const SceneObject& o) {
  TriangleMesh m = *o.shared_mesh;
  m.transform(o.placement);
  return same_bits(m, o.mesh);
}

}  // namespace penumbra::testing
