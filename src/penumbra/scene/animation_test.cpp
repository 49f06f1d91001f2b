#include "penumbra/scene/animation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "penumbra/core/testing.h"
#include "penumbra/scene/json_reader.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using nlohmann::json;
using test::error_message;

const char* kOrigin = "scenes/t.json";

Track scalar_track(Interpolation interpolation, std::vector<std::pair<double, double>> keys) {
  std::vector<Track::Key> k;
  for (auto [frame, value] : keys) k.push_back({frame, {value, 0, 0}});
  return Track(interpolation, std::move(k));
}

TEST(AnimationTrack, LinearIsTheLineBetweenKeys) {
  Track t(Interpolation::Linear, {{0, {0, 0, 0}}, {10, {2, 4, -6}}, {20, {2, 0, 0}}});
  EXPECT_EQ(t.at(5), (Track::Value{1, 2, -3}));  // the midpoint
  EXPECT_EQ(t.at(2.5), (Track::Value{0.5, 1, -1.5}));
  EXPECT_EQ(t.at(15), (Track::Value{2, 2, -3}));
  for (const Track::Key& k : t.keys()) EXPECT_EQ(t.at(k.frame), k.value);
}

TEST(AnimationTrack, CatmullRomMatchesTheClosedForm) {
  // Keys 0, 1, 3, 4 at frames 0, 10, 20, 30: on [10, 20] the tangents are
  // (3 - 0) / 20 = 0.15 and (4 - 1) / 20 = 0.15 per frame, h = 10, so with the Hermite basis
  // p(s) = h00 1 + h10 1.5 + h01 3 + h11 1.5:
  //   s = 0.5:  0.5 + 0.1875 + 1.5 - 0.1875 = 2
  //   s = 0.25: 0.84375 + 0.2109375 + 0.46875 - 0.0703125 = 1.453125
  Track t = scalar_track(Interpolation::CatmullRom, {{0, 0}, {10, 1}, {20, 3}, {30, 4}});
  EXPECT_DOUBLE_EQ(t.at(15)[0], 2.0);
  EXPECT_DOUBLE_EQ(t.at(12.5)[0], 1.453125);
  // It passes through every key.
  for (const Track::Key& k : t.keys()) EXPECT_EQ(t.at(k.frame), k.value);
  // First segment, clamped end tangent: the slope to the one neighbour, (1 - 0) / 10 = 0.1;
  // at key 1, 0.15. s = 0.5, h = 10: 0 + 0.125 * 10 * 0.1 + 0.5 - 0.125 * 10 * 0.15 = 0.4375.
  EXPECT_DOUBLE_EQ(t.at(5)[0], 0.4375);
  // Unevenly spaced keys: tangents over the actual frame spans. Keys 0, 2, 2 at frames 0, 4,
  // 12: on [4, 12] (h = 8) the tangents are (2 - 0) / 12 and (2 - 2) / 8 = 0; at s = 0.5:
  // 0.5 * 2 + 0.125 * 8 / 6 + 0.5 * 2 - 0 = 2 + 1/6.
  Track u = scalar_track(Interpolation::CatmullRom, {{0, 0}, {4, 2}, {12, 2}});
  EXPECT_NEAR(u.at(8)[0], 2.0 + 1.0 / 6.0, 1e-12);
}

TEST(AnimationTrack, TwoKeyCatmullRomIsTheLine) {
  Track c = scalar_track(Interpolation::CatmullRom, {{2, 1}, {6, 9}});
  Track l = scalar_track(Interpolation::Linear, {{2, 1}, {6, 9}});
  for (double f = 2; f <= 6; f += 0.5) EXPECT_NEAR(c.at(f)[0], l.at(f)[0], 1e-12) << f;
}

TEST(AnimationTrack, ClampsOutsideTheKeysAndOneKeyIsConstant) {
  for (Interpolation i : {Interpolation::Linear, Interpolation::CatmullRom}) {
    Track t = scalar_track(i, {{5, 1}, {10, 3}, {15, 2}});
    EXPECT_EQ(t.at(0)[0], 1);
    EXPECT_EQ(t.at(4.9)[0], 1);
    EXPECT_EQ(t.at(16)[0], 2);
    EXPECT_EQ(t.at(1000)[0], 2);
    Track one = scalar_track(i, {{7, 4}});
    for (double f : {0.0, 7.0, 99.0}) EXPECT_EQ(one.at(f)[0], 4);
  }
}

// ---------------------------------------------------------------------------------------------
// The block in a scene file

json animated_doc() {
  return json::parse(R"({
    "camera": {"eye": [0, 1, 5], "target": [0, 0, 0]},
    "lights": [{"type": "rect", "center": [0, 3, 0], "normal": [0, -1, 0], "u": [1, 0, 0], "size": [1, 2]},
               {"type": "sphere", "center": [3, 3, 0], "radius": 0.5}],
    "objects": [{"name": "ground", "shape": "plane", "size": [4, 4]},
                {"name": "crate", "shape": "box", "size": [1, 1, 1], "scale": 2, "translate": [1, 0.5, 0]}],
    "animation": {
      "frames": 11, "fps": 12,
      "camera": {"eye": [{"frame": 0, "value": [0, 1, 5]}, {"frame": 10, "value": [5, 1, 0]}],
                 "fov_y": {"interpolation": "catmull-rom", "keys": [{"frame": 0, "value": 40}, {"frame": 4, "value": 50},
                                                                     {"frame": 10, "value": 40}]}},
      "lights": {"0": {"center": [{"frame": 2, "value": [0, 3, 0]}, {"frame": 6, "value": [2, 3, 0]}],
                       "normal": [{"frame": 0, "value": [0, -1, 0]}, {"frame": 10, "value": [1, -1, 0]}]}},
      "objects": {"crate": {"rotate": [{"frame": 0, "value": [0, 0, 0]}, {"frame": 10, "value": [0, 90, 0]}]}}
    }
  })");
}

void expect_same_scene(const Scene& a, const Scene& b) {
  EXPECT_EQ(a.camera.eye, b.camera.eye);
  EXPECT_EQ(a.camera.target, b.camera.target);
  EXPECT_EQ(a.camera.up, b.camera.up);
  EXPECT_EQ(a.camera.fov_y, b.camera.fov_y);
  ASSERT_EQ(a.lights.size(), b.lights.size());
  for (size_t i = 0; i < a.lights.size(); ++i) {
    EXPECT_EQ(a.lights[i].center, b.lights[i].center) << i;
    EXPECT_EQ(a.lights[i].frame.n, b.lights[i].frame.n) << i;
    EXPECT_EQ(a.lights[i].frame.s, b.lights[i].frame.s) << i;
    EXPECT_EQ(a.lights[i].size.x, b.lights[i].size.x) << i;
  }
  ASSERT_EQ(a.objects.size(), b.objects.size());
  for (size_t i = 0; i < a.objects.size(); ++i) {
    EXPECT_EQ(a.objects[i].mesh.positions, b.objects[i].mesh.positions) << i;
    EXPECT_EQ(a.objects[i].mesh.normals, b.objects[i].mesh.normals) << i;
    EXPECT_EQ(a.objects[i].mesh.indices, b.objects[i].mesh.indices) << i;
  }
}

TEST(AnimationFile, LoadsAsWrittenAndGivesEachFrame) {
  Scene base = parse_scene(animated_doc(), kOrigin);
  ASSERT_TRUE(base.animation);
  EXPECT_EQ(base.animation->frames, 11);
  EXPECT_EQ(base.animation->fps, 12.0f);
  // The scene as loaded is the scene as written.
  json still = animated_doc();
  still.erase("animation");
  Scene written = parse_scene(still, kOrigin);
  EXPECT_FALSE(written.animation);
  expect_same_scene(base, written);

  Scene f5 = scene_at_frame(base, 5);
  EXPECT_EQ(f5.camera.eye, Vec3f(2.5f, 1, 2.5f));
  EXPECT_EQ(f5.camera.target, base.camera.target);  // not animated: as written
  EXPECT_EQ(f5.lights[0].center, Vec3f(1.5f, 3, 0));
  EXPECT_EQ(scene_at_frame(base, 0).lights[0].center, Vec3f(0, 3, 0));  // clamped before the first key
  EXPECT_EQ(scene_at_frame(base, 9).lights[0].center, Vec3f(2, 3, 0));  // and after the last
  EXPECT_EQ(scene_at_frame(base, 4).camera.fov_y, 50.0f);                // Catmull-Rom hits its keys
  // The animated normal keeps the light's u: frame.s is u projected onto the light's plane.
  const Scene f10 = scene_at_frame(base, 10);
  const Frame& lf = f10.lights[0].frame;
  EXPECT_NEAR(lf.n.x, std::sqrt(0.5f), 1e-6f);
  EXPECT_NEAR(lf.s.x, std::sqrt(0.5f), 1e-6f);
  EXPECT_NEAR(lf.s.y, std::sqrt(0.5f), 1e-6f);
  // Each frame comes from the scene as written, whatever scene it is asked of.
  expect_same_scene(scene_at_frame(scene_at_frame(base, 7), 3), scene_at_frame(base, 3));
  EXPECT_TRUE(base.animation->objects_differ(0, 1));
  EXPECT_NE(error_message([&] { scene_at_frame(base, 11); }).find("frame 11 is outside"), std::string::npos);
  EXPECT_NE(error_message([&] { scene_at_frame(written, 0); }).find("no \"animation\" block"), std::string::npos);
}

TEST(AnimationFile, RotatingObjectsVerticesFollowTheClosedForm) {
  Scene base = parse_scene(animated_doc(), kOrigin);
  const TriangleMesh unit_box = parse_scene(json::parse(R"({
    "camera": {"eye": [0, 1, 5], "target": [0, 0, 0]},
    "lights": [{"type": "sphere", "center": [0, 3, 0], "radius": 0.5}],
    "objects": [{"shape": "box", "size": [1, 1, 1]}]})"), kOrigin).objects[0].mesh;
  for (int frame : {0, 3, 7, 10}) {
    Scene s = scene_at_frame(base, frame);
    const TriangleMesh& m = s.objects[1].mesh;
    ASSERT_EQ(m.positions.size(), unit_box.positions.size());
    // The object's own scale 2 and translate (1, 0.5, 0) around the keyed rotation about y,
    // 9 degrees per frame: x' = 2 (x cos + z sin) + 1, y' = 2 y + 0.5, z' = 2 (-x sin + z cos).
    const double a = frame * 9.0 * M_PI / 180.0;
    for (size_t i = 0; i < m.positions.size(); ++i) {
      const Vec3f p = unit_box.positions[i], q = m.positions[i];
      EXPECT_NEAR(q.x, 2 * (p.x * std::cos(a) + p.z * std::sin(a)) + 1, 1e-5) << frame;
      EXPECT_NEAR(q.y, 2 * p.y + 0.5, 1e-5) << frame;
      EXPECT_NEAR(q.z, 2 * (-p.x * std::sin(a) + p.z * std::cos(a)), 1e-5) << frame;
    }
    EXPECT_EQ(s.objects[0].mesh.positions, base.objects[0].mesh.positions);  // the ground stays
    EXPECT_TRUE(s.objects[1].closed);
  }
}

TEST(AnimationFile, AFrameEqualsTheStaticSceneOfItsValuesBitForBit) {
  // At frame 5 the keys give eye (2.5, 1, 2.5), light centre (1.5, 3, 0), rotate y 45 and the
  // scale 0.5 -> 1.5 halfway, 1: the same scene written without an animation.
  json d = animated_doc();
  d["animation"]["objects"]["crate"]["scale"] = json::parse(R"([{"frame": 0, "value": 0.5}, {"frame": 10, "value": [1.5, 1.5, 1.5]}])");
  d["animation"].erase("camera");
  d["animation"]["lights"]["0"].erase("normal");
  json still = d;
  still.erase("animation");
  still["lights"][0]["center"] = {1.5, 3, 0};
  still["objects"][1]["rotate"] = {0, 45, 0};
  still["objects"][1]["scale"] = 1;
  expect_same_scene(scene_at_frame(parse_scene(d, kOrigin), 5), parse_scene(still, kOrigin));
}

TEST(AnimationFile, GeneratorPartsMoveTogetherAndStaticScenesHaveNone) {
  json d = animated_doc();
  d["objects"][1] = {{"generator", "furball"}, {"params", {{"strands", 10}, {"body_segments", 8}}}};
  d["animation"]["objects"] = {{"furball", {{"translate", json::parse(R"([{"frame": 0, "value": [0, 0, 0]},
                                                                          {"frame": 10, "value": [0, 2, 0]}])")}}}};
  Scene base = parse_scene(d, kOrigin);
  Scene s = scene_at_frame(base, 10);
  ASSERT_EQ(s.objects.size(), 3u);  // ground, furball.body, furball.hair
  for (size_t i = 1; i < 3; ++i) {
    EXPECT_NEAR(s.objects[i].mesh.bounds().lo.y, base.objects[i].mesh.bounds().lo.y + 2, 1e-5) << s.objects[i].name;
  }
  ASSERT_TRUE(s.objects[1].sphere);  // the analytic body moves with its tessellation
  EXPECT_NEAR(s.objects[1].sphere->center.y, base.objects[1].sphere->center.y + 2, 1e-5);
  // The sphere light faces the objects as they are at the frame.
  EXPECT_NE(s.lights[1].frame.n, base.lights[1].frame.n);
  // Only the camera and lights move: the geometry is the same from frame to frame.
  d["animation"].erase("objects");
  EXPECT_FALSE(parse_scene(d, kOrigin).animation->objects_differ(0, 10));
}

struct BadCase {
  const char* what;
  std::function<void(json&)> edit;
  const char* expected;  // the whole message
};

TEST(AnimationFile, RejectsBadBlocksNamingTheKey) {
  const std::vector<BadCase> cases = {
      {"unknown key", [](json& a) { a["speed"] = 1; },
       "scenes/t.json: animation.speed: unknown key (allowed here: frames, fps, camera, lights, objects)"},
      {"missing frames", [](json& a) { a.erase("frames"); }, "scenes/t.json: animation.frames: required key is missing"},
      {"zero frames", [](json& a) { a["frames"] = 0; },
       "scenes/t.json: animation.frames: expected an integer in [1, 100000], got 0"},
      {"bad fps", [](json& a) { a["fps"] = -24; }, "scenes/t.json: animation.fps: expected a positive number, got -24"},
      {"unknown camera key", [](json& a) { a["camera"]["resolution"] = json::array(); },
       "scenes/t.json: animation.camera.resolution: unknown key (allowed here: eye, target, up, fov_y)"},
      {"track of wrong type", [](json& a) { a["camera"]["eye"] = 3; },
       "scenes/t.json: animation.camera.eye: expected a list of keys {\"frame\": f, \"value\": ...} or "
       "{\"interpolation\": ..., \"keys\": [...]}, got 3"},
      {"no keys", [](json& a) { a["camera"]["eye"] = json::array(); },
       "scenes/t.json: animation.camera.eye: expected at least one key"},
      {"frames out of order", [](json& a) { a["camera"]["eye"].push_back({{"frame", 3}, {"value", {0, 0, 1}}}); },
       "scenes/t.json: animation.camera.eye[2].frame: keys must be in increasing frame order (frame 3 after frame 10)"},
      {"two keys at one frame", [](json& a) { a["camera"]["eye"][1]["frame"] = 0; },
       "scenes/t.json: animation.camera.eye[1].frame: keys must be in increasing frame order (frame 0 after frame 0)"},
      {"frame past the end", [](json& a) { a["camera"]["eye"][1]["frame"] = 11; },
       "scenes/t.json: animation.camera.eye[1].frame: expected an integer in [0, 10], got 11"},
      {"negative frame", [](json& a) { a["camera"]["eye"][0]["frame"] = -1; },
       "scenes/t.json: animation.camera.eye[0].frame: expected an integer in [0, 10], got -1"},
      {"fractional frame", [](json& a) { a["camera"]["eye"][0]["frame"] = 0.5; },
       "scenes/t.json: animation.camera.eye[0].frame: expected an integer in [0, 10], got 0.5"},
      {"missing value", [](json& a) { a["camera"]["eye"][0].erase("value"); },
       "scenes/t.json: animation.camera.eye[0].value: required key is missing"},
      {"unknown key in a key", [](json& a) { a["camera"]["eye"][0]["ease"] = "in"; },
       "scenes/t.json: animation.camera.eye[0].ease: unknown key (allowed here: frame, value)"},
      {"value of wrong type", [](json& a) { a["camera"]["eye"][0]["value"] = "left"; },
       "scenes/t.json: animation.camera.eye[0].value: expected three finite numbers, got \"left\""},
      {"value as the key checks it", [](json& a) { a["camera"]["fov_y"]["keys"][1]["value"] = 180; },
       "scenes/t.json: animation.camera.fov_y.keys[1].value: expected an angle in degrees in (0, 180), got 180"},
      {"unknown interpolation", [](json& a) { a["camera"]["fov_y"]["interpolation"] = "cubic"; },
       "scenes/t.json: animation.camera.fov_y.interpolation: expected one of \"linear\", \"catmull-rom\", got \"cubic\""},
      {"unknown track key", [](json& a) { a["camera"]["fov_y"]["loop"] = true; },
       "scenes/t.json: animation.camera.fov_y.loop: unknown key (allowed here: interpolation, keys)"},
      {"Catmull-Rom overshoot", [](json& a) {
         a["camera"]["fov_y"]["keys"] = json::parse(R"([{"frame": 0, "value": 5}, {"frame": 1, "value": 170},
                                                       {"frame": 9, "value": 170}, {"frame": 10, "value": 5}])");
       },
       "scenes/t.json: animation.camera.fov_y: at frame 2: expected an angle in degrees in (0, 180), got 186.042 "
       "(Catmull-Rom overshoots between keys; linear does not)"},
      {"eye through target", [](json& a) { a["camera"]["eye"][1]["value"] = {0, -1, -5}; },
       "scenes/t.json: animation.camera: at frame 5: eye and target coincide"},
      {"light index not a number", [](json& a) { a["lights"]["first"] = a["lights"]["0"]; },
       "scenes/t.json: animation.lights.first: expected a light index in [0, 1] as the key"},
      {"light index with a leading zero", [](json& a) { a["lights"]["01"] = json::object(); },
       "scenes/t.json: animation.lights.01: expected a light index in [0, 1] as the key"},
      {"no such light", [](json& a) { a["lights"]["2"] = json::object(); },
       "scenes/t.json: animation.lights[2]: no such light (the scene has 2 lights)"},
      {"key the light's shape lacks", [](json& a) { a["lights"]["1"] = {{"normal", a["lights"]["0"]["normal"]}}; },
       "scenes/t.json: animation.lights[1].normal: unknown key (allowed here: center, radiance, radius)"},
      {"light value", [](json& a) { a["lights"]["0"]["size"] = json::parse(R"([{"frame": 0, "value": [1, 0]}])"); },
       "scenes/t.json: animation.lights[0].size[0].value: expected two positive numbers, got [1,0]"},
      {"normal through zero", [](json& a) { a["lights"]["0"]["normal"][1]["value"] = {0, 1, 0}; },
       "scenes/t.json: animation.lights[0].normal: at frame 5: expected three numbers, not all zero, got [0,0,0]"},
      {"normal along u", [](json& a) { a["lights"]["0"]["normal"][1]["value"] = {1, 0, 0}; },
       "scenes/t.json: animation.lights[0].normal: at frame 10: expected a normal not parallel to the light's u, got "
       "[1,0,0]"},
      {"unknown object", [](json& a) { a["objects"]["box"] = a["objects"]["crate"]; },
       "scenes/t.json: animation.objects.box: no object of that name (the objects: ground, crate)"},
      {"unknown object key", [](json& a) { a["objects"]["crate"]["shear"] = json::array(); },
       "scenes/t.json: animation.objects.crate.shear: unknown key (allowed here: translate, rotate, scale)"},
      {"zero scale key", [](json& a) { a["objects"]["crate"]["scale"] = json::parse(R"([{"frame": 0, "value": 0}])"); },
       "scenes/t.json: animation.objects.crate.scale[0].value: expected a non-zero number or three non-zero numbers, got 0"},
      {"scale through zero", [](json& a) {
         a["objects"]["crate"]["scale"] = json::parse(R"([{"frame": 0, "value": 1}, {"frame": 10, "value": [1, -1, 1]}])");
       },
       "scenes/t.json: animation.objects.crate.scale: at frame 5: expected a non-zero scale, got [1,0,1]"},
  };
  for (const auto& c : cases) {
    json d = animated_doc();
    c.edit(d["animation"]);
    std::string msg = error_message([&] { parse_scene(d, kOrigin); });
    EXPECT_EQ(msg, c.expected) << c.what;
  }
  // Two objects of one name: which one the animation moves would be a guess.
  json d = animated_doc();
  d["objects"][0]["name"] = "crate";
  EXPECT_EQ(error_message([&] { parse_scene(d, kOrigin); }),
            "scenes/t.json: animation.objects.crate: two objects are named \"crate\" (objects[0] and objects[1]): give "
            "the animated one a name of its own");
  d = animated_doc();
  d["animation"] = 24;
  EXPECT_EQ(error_message([&] { parse_scene(d, kOrigin); }), "scenes/t.json: animation: expected an object, got 24");
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
