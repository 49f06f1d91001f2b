#include "penumbra/scene/scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>

#include "penumbra/core/file_util.h"
#include "penumbra/core/image.h"
#include "penumbra/core/testing.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene/json_reader.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

namespace fs = std::filesystem;
using nlohmann::json;
using test::error_message;

const char* kOrigin = "scenes/t.json";

json minimal_doc() {
  return json::parse(R"({
    "camera": {"eye": [0, 1, 5], "target": [0, 0, 0]},
    "lights": [{"type": "rect", "center": [0, 3, 0], "normal": [0, -1, 0], "size": [1, 2]}],
    "objects": [{"shape": "plane", "size": [4, 4]}, {"shape": "box", "size": [1, 1, 1]}]
  })");
}

void expect_near(Vec3f a, Vec3f b, float eps = 1e-5f) {
  EXPECT_NEAR(a.x, b.x, eps);
  EXPECT_NEAR(a.y, b.y, eps);
  EXPECT_NEAR(a.z, b.z, eps);
}

TEST(SceneFile, MinimalSceneAndDefaults) {
  Scene s = parse_scene(minimal_doc(), kOrigin);
  EXPECT_EQ(s.source, fs::path(kOrigin));
  EXPECT_EQ(s.camera.fov_y, 45.0f);
  EXPECT_EQ(s.camera.width, 512);
  EXPECT_EQ(s.camera.height, 512);
  EXPECT_EQ(s.camera.samples_per_pixel, 1);
  expect_near(s.camera.up, {0, 1, 0});
  ASSERT_EQ(s.lights.size(), 1u);
  const AreaLight& l = s.lights[0];
  EXPECT_EQ(l.shape, LightShape::Rect);
  expect_near(l.radiance, {1, 1, 1});
  // Default u: world x projected onto the light plane; t = n x s.
  expect_near(l.frame.n, {0, -1, 0});
  expect_near(l.frame.s, {1, 0, 0});
  expect_near(l.frame.t, {0, 0, 1});
  EXPECT_EQ(l.size.y, 2.0f);
  ASSERT_EQ(s.objects.size(), 2u);
  EXPECT_EQ(s.objects[0].name, "plane");
  EXPECT_FALSE(s.objects[0].closed);
  EXPECT_TRUE(s.objects[1].closed);
  EXPECT_EQ(s.triangle_count(), 2u + 12u);
  expect_near(s.bounds().lo, {-2, -0.5f, -2});
  EXPECT_TRUE(s.method_params.empty());
}

// The resolved camera and lights (what the viewer's page reads) hold every key of the format
// but a texture, the parser's own values for those left out, and parse back to the same
// camera and frames bit for bit.
TEST(SceneFile, ResolvedCameraAndLightsFillEveryDefault) {
  const json camera = json::parse(R"({"eye": [0, 1, 5], "target": [0, 0, 0]})");
  const json lights = json::parse(R"([
    {"type": "rect", "center": [0, 3, 0], "normal": [0.3, -1, 0.2], "size": [1, 2]},
    {"type": "rect", "center": [0, 3, 0], "normal": [-1, 0, 0], "size": [1, 2], "radiance": [2, 3, 4]},
    {"type": "disk", "center": [1, 3, 0], "normal": [0, -1, 0.5], "radius": 0.5},
    {"type": "ellipsoid", "center": [0, 2, 1], "normal": [0.2, -1, 0], "radii": [0.5, 0.2, 0.1]},
    {"type": "sphere", "center": [2, 3, 0], "radius": 0.3}])");
  const Camera c = parse_camera(camera, kOrigin);
  const std::vector<AreaLight> parsed = parse_lights(lights, kOrigin);
  const json rc = resolved_camera_json(camera, c);
  for (std::string_view key : camera_keys()) EXPECT_TRUE(rc.contains(key)) << "camera." << key;
  EXPECT_EQ(rc.size(), camera_keys().size());
  EXPECT_EQ(rc["up"], json::array({0, 1, 0}));
  EXPECT_EQ(rc["fov_y"], 45);
  EXPECT_EQ(rc["resolution"], json::array({512, 512}));
  EXPECT_EQ(rc["samples_per_pixel"], 1);
  EXPECT_EQ(rc["eye"], camera["eye"]);  // given keys as written
  const Camera back = parse_camera(rc, kOrigin);
  EXPECT_EQ(back.up, c.up);
  EXPECT_EQ(back.fov_y, c.fov_y);
  EXPECT_EQ(back.width, c.width);

  const json rl = resolved_lights_json(lights, parsed);
  ASSERT_EQ(rl.size(), lights.size());
  for (size_t i = 0; i < rl.size(); ++i) {
    for (std::string_view key : light_keys(parsed[i].shape))
      if (key != "radiance_texture") EXPECT_TRUE(rl[i].contains(key)) << "lights[" << i << "]." << key;
  }
  EXPECT_EQ(rl[0]["u"], json::array({1, 0, 0}));  // the default rule's vector, not its projection
  EXPECT_EQ(rl[1]["u"], json::array({0, 0, 1}));  // normal along x: z
  EXPECT_EQ(rl[0]["radiance"], json::array({1, 1, 1}));
  EXPECT_EQ(rl[1]["radiance"], json::array({2, 3, 4}));
  EXPECT_FALSE(rl[4].contains("u"));  // a sphere has no frame of its own to give
  const std::vector<AreaLight> again = parse_lights(rl, kOrigin);
  for (size_t i = 0; i < 2; ++i) {  // rects: the same frame bit for bit
    EXPECT_EQ(again[i].frame.s, parsed[i].frame.s) << i;
    EXPECT_EQ(again[i].frame.t, parsed[i].frame.t) << i;
  }
  for (size_t i = 2; i < 4; ++i) {  // disk, ellipsoid: the frame's own axes
    expect_near(again[i].frame.s, parsed[i].frame.s, 1e-6f);
    expect_near(again[i].frame.t, parsed[i].frame.t, 1e-6f);
  }
}

TEST(SceneFile, LightsAndMethods) {
  json d = minimal_doc();
  d["lights"] = json::parse(R"([
    {"type": "rect", "center": [0, 3, 0], "normal": [0, 0, 2], "u": [0, 1, 0.5], "size": [1, 1],
     "radiance": [5, 4, 3]},
    {"type": "disk", "center": [1, 3, 0], "normal": [0, -1, 0], "radius": 0.25},
    {"type": "sphere", "center": [0, 5, 0], "radius": 0.5}
  ])");
  d["methods"] = {{"lam", {{"samples", 64}}}};
  Scene s = parse_scene(d, kOrigin);
  expect_near(s.lights[0].frame.n, {0, 0, 1});
  expect_near(s.lights[0].frame.s, {0, 1, 0});  // u projected onto the plane
  expect_near(s.lights[0].radiance, {5, 4, 3});
  EXPECT_EQ(s.lights[1].shape, LightShape::Disk);
  EXPECT_EQ(s.lights[1].radius, 0.25f);
  expect_near(s.lights[1].frame.n, {0, -1, 0});
  // Sphere: frame.n from the light toward the centre of the objects' bounds (0, 0, 0).
  EXPECT_EQ(s.lights[2].shape, LightShape::Sphere);
  expect_near(s.lights[2].frame.n, {0, -1, 0});
  EXPECT_EQ(s.method_params["lam"]["samples"], 64);
}

TEST(SceneFile, EllipsoidLight) {
  json d = minimal_doc();
  d["lights"] = json::parse(R"([
    {"type": "ellipsoid", "center": [0, 3, 0], "radii": [0.8, 0.3, 0.2], "u": [1, 0, 1], "normal": [0, -2, 0],
     "radiance": [2, 2, 2]}
  ])");
  Scene s = parse_scene(d, kOrigin);
  const AreaLight& l = s.lights[0];
  EXPECT_EQ(l.shape, LightShape::Ellipsoid);
  expect_near(l.radii, {0.8f, 0.3f, 0.2f});
  expect_near(l.frame.n, {0, -1, 0});  // the given axis (not reset toward the scene)
  expect_near(l.frame.s, normalize(Vec3f(1, 0, 1)));
  EXPECT_FLOAT_EQ(l.diameter(), 1.6f);
  // Without u: any frame around normal.
  d["lights"][0].erase("u");
  expect_near(parse_scene(d, kOrigin).lights[0].frame.n, {0, -1, 0});

  auto error_with = [&](const char* light_json) {
    json e = minimal_doc();
    e["lights"] = json::array({json::parse(light_json)});
    return error_message([&] { parse_scene(e, kOrigin); });
  };
  EXPECT_EQ(error_with(R"({"type": "ellipsoid", "center": [0, 3, 0], "normal": [0, -1, 0]})"),
            "scenes/t.json: lights[0].radii: required key is missing");
  EXPECT_EQ(error_with(R"({"type": "ellipsoid", "center": [0, 3, 0], "radii": [1, -1, 1], "normal": [0, -1, 0]})"),
            "scenes/t.json: lights[0].radii: expected three positive numbers, got [1,-1,1]");
  EXPECT_EQ(error_with(R"({"type": "ellipsoid", "center": [0, 3, 0], "radii": [1, 1], "normal": [0, -1, 0]})"),
            "scenes/t.json: lights[0].radii: expected three positive numbers, got [1,1]");
  EXPECT_EQ(error_with(R"({"type": "ellipsoid", "center": [0, 3, 0], "radii": [1, 1, 1]})"),
            "scenes/t.json: lights[0].normal: required key is missing");
  EXPECT_EQ(error_with(R"({"type": "ellipsoid", "center": [0, 3, 0], "radii": [1, 1, 1], "normal": [0, -1, 0],
                           "radius": 1})").substr(0, 44),
            "scenes/t.json: lights[0].radius: unknown key");
  EXPECT_EQ(error_with(R"({"type": "ellipsoid", "center": [0, 3, 0], "radii": [1, 1, 1], "normal": [0, -1, 0],
                           "u": [0, 2, 0]})"),
            "scenes/t.json: lights[0].u: must not be parallel to normal");
}

TEST(SceneFile, TransformsScaleThenRotateXYZThenTranslate) {
  json d = minimal_doc();
  // The UV sphere's vertex 0 is its north pole (0, r, 0).
  d["objects"] = json::parse(R"([
    {"name": "a", "shape": "sphere", "radius": 1, "segments": 8, "rotate": [90, 90, 0]},
    {"name": "b", "shape": "sphere", "radius": 1, "segments": 8, "scale": [1, 2, 3],
     "rotate": [0, 0, 90], "translate": [10, 0, 0]},
    {"name": "c", "shape": "sphere", "radius": 0.5, "scale": 2, "translate": [1, 2, 3]},
    {"name": "d", "shape": "box", "size": [2, 2, 2], "scale": [1, 2, 3], "rotate": [0, 90, 0],
     "translate": [10, 0, 0]}
  ])");
  Scene s = parse_scene(d, kOrigin);
  // Rx(90) takes the pole (0,1,0) to (0,0,1), then Ry(90) to (1,0,0). The other order
  // would leave it at (0,0,1).
  expect_near(s.objects[0].mesh.positions[0], {1, 0, 0});
  // Scale (1,2,3): pole (0,2,0); Rz(90): (-2,0,0); translate: (8,0,0).
  expect_near(s.objects[1].mesh.positions[0], {8, 0, 0});
  EXPECT_FALSE(s.objects[1].sphere.has_value());  // non-uniform scale: no longer a sphere
  ASSERT_TRUE(s.objects[2].sphere.has_value());
  expect_near(s.objects[2].sphere->center, {1, 2, 3});
  EXPECT_NEAR(s.objects[2].sphere->radius, 1.0f, 1e-6f);
  // Box corner (1,1,1) -> scale (1,2,3) -> Ry(90): (x,z) -> (z,-x) = (3,2,-1) -> +10 x.
  Bounds3f b = s.objects[3].mesh.bounds();
  expect_near(b.lo, {7, -2, -1});
  expect_near(b.hi, {13, 2, 1});
  EXPECT_TRUE(s.objects[3].closed);
}

TEST(SceneFile, MaterialsAndNames) {
  json d = minimal_doc();
  d["objects"][1]["name"] = "crate";
  d["objects"][1]["material"] = {{"albedo", {0.1, 0.2, 0.3}}, {"opacity", 0.5}, {"two_sided", false}};
  Scene s = parse_scene(d, kOrigin);
  EXPECT_EQ(s.objects[1].name, "crate");
  expect_near(s.objects[1].material.albedo, {0.1f, 0.2f, 0.3f});
  EXPECT_EQ(s.objects[1].material.opacity, 0.5f);
  EXPECT_FALSE(s.objects[1].material.two_sided);
  EXPECT_EQ(s.objects[0].material.opacity, 1.0f);
}

TEST(SceneFile, MeshPathsAreRelativeToTheSceneFile) {
  test::TempDir dir("scene-paths");
  fs::create_directories(dir / "sub" / "meshes");
  write_text_file_atomic(dir / "sub" / "meshes" / "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  json d = minimal_doc();
  d["objects"][1] = {{"mesh", "meshes/tri.obj"}};
  write_text_file_atomic(dir / "sub" / "s.json", d.dump());
  Scene s = load_scene(dir / "sub" / "s.json");
  EXPECT_EQ(s.objects[1].name, "tri");
  EXPECT_EQ(s.objects[1].mesh.triangle_count(), 1u);
  // Absolute paths too.
  d["objects"][1] = {{"mesh", (dir / "sub" / "meshes" / "tri.obj").string()}};
  EXPECT_EQ(parse_scene(d, "elsewhere/x.json").objects[1].mesh.triangle_count(), 1u);
}

TEST(SceneFile, CommentsAreAllowed) {
  json d = parse_json_text("{\"a\": 1, // a comment\n \"b\": [1, /* two */ 2]}", "c.json");
  EXPECT_EQ(d["b"][1], 2);
}

// ---------------------------------------------------------------------------
// Every class of bad input: the error is one line starting with the file and the key path.

struct BadCase {
  const char* what;
  std::function<void(json&)> edit;
  const char* expected;  // the message must contain this
};

TEST(SceneFile, RejectsBadInputNamingFileAndKey) {
  const std::vector<BadCase> cases = {
      {"unknown top-level key", [](json& d) { d["lightz"] = 1; }, "scenes/t.json: lightz: unknown key"},
      {"unknown light key", [](json& d) { d["lights"][0]["colour"] = 1; },
       "scenes/t.json: lights[0].colour: unknown key"},
      {"unknown camera key", [](json& d) { d["camera"]["fov"] = 30; }, "scenes/t.json: camera.fov: unknown key"},
      {"unknown object key", [](json& d) { d["objects"][1]["radius"] = 1; },
       "scenes/t.json: objects[1].radius: unknown key"},
      {"missing camera", [](json& d) { d.erase("camera"); }, "scenes/t.json: camera: required key is missing"},
      {"missing eye", [](json& d) { d["camera"].erase("eye"); }, "scenes/t.json: camera.eye: required key is missing"},
      {"wrong type", [](json& d) { d["camera"]["fov_y"] = "wide"; }, "scenes/t.json: camera.fov_y: expected"},
      {"fov out of range", [](json& d) { d["camera"]["fov_y"] = 180; }, "scenes/t.json: camera.fov_y: expected"},
      {"vector of strings", [](json& d) { d["camera"]["eye"] = {"a", "b", "c"}; },
       "scenes/t.json: camera.eye: expected three finite numbers"},
      {"vector too short", [](json& d) { d["camera"]["target"] = {0, 0}; }, "scenes/t.json: camera.target: expected"},
      {"eye equals target", [](json& d) { d["camera"]["target"] = {0, 1, 5}; }, "scenes/t.json: camera.target:"},
      {"up parallel", [](json& d) { d["camera"]["up"] = {0, 2, 10}; }, "scenes/t.json: camera.up: must not be parallel"},
      {"resolution zero", [](json& d) { d["camera"]["resolution"] = {0, 512}; }, "scenes/t.json: camera.resolution"},
      {"resolution negative", [](json& d) { d["camera"]["resolution"] = {512, -1}; },
       "scenes/t.json: camera.resolution"},
      {"resolution fractional", [](json& d) { d["camera"]["resolution"] = {512.5, 512}; },
       "scenes/t.json: camera.resolution"},
      {"samples zero", [](json& d) { d["camera"]["samples_per_pixel"] = 0; },
       "scenes/t.json: camera.samples_per_pixel: expected an integer"},
      {"no lights", [](json& d) { d["lights"] = json::array(); }, "scenes/t.json: lights: expected at least one light"},
      {"lights not an array", [](json& d) { d["lights"] = json::object(); }, "scenes/t.json: lights: expected an array"},
      {"no objects", [](json& d) { d["objects"] = json::array(); },
       "scenes/t.json: objects: expected at least one object"},
      {"light type", [](json& d) { d["lights"][0]["type"] = "spot"; }, "scenes/t.json: lights[0].type: expected one of"},
      {"zero size", [](json& d) { d["lights"][0]["size"] = {1, 0}; },
       "scenes/t.json: lights[0].size: expected two positive numbers"},
      {"negative size", [](json& d) { d["lights"][0]["size"] = {-1, 1}; },
       "scenes/t.json: lights[0].size: expected two positive numbers"},
      {"zero normal", [](json& d) { d["lights"][0]["normal"] = {0, 0, 0}; },
       "scenes/t.json: lights[0].normal: expected three numbers, not all zero"},
      {"u parallel to normal", [](json& d) { d["lights"][0]["u"] = {0, 2, 0}; },
       "scenes/t.json: lights[0].u: must not be parallel to normal"},
      {"negative radiance", [](json& d) { d["lights"][0]["radiance"] = {1, -1, 1}; },
       "scenes/t.json: lights[0].radiance: expected three non-negative numbers"},
      {"zero disk radius",
       [](json& d) { d["lights"][0] = {{"type", "disk"}, {"center", {0, 3, 0}}, {"normal", {0, -1, 0}}, {"radius", 0}}; },
       "scenes/t.json: lights[0].radius: expected a positive number"},
      {"negative sphere radius",
       [](json& d) { d["lights"][0] = {{"type", "sphere"}, {"center", {0, 3, 0}}, {"radius", -1}}; },
       "scenes/t.json: lights[0].radius: expected a positive number"},
      {"normal on a sphere light",
       [](json& d) { d["lights"][0] = {{"type", "sphere"}, {"center", {0, 3, 0}}, {"radius", 1}, {"normal", {0, 1, 0}}}; },
       "scenes/t.json: lights[0].normal: unknown key"},
      {"infinite number in the DOM", [](json& d) { d["lights"][0]["center"] = {0, INFINITY, 0}; },
       "scenes/t.json: lights[0].center: expected three finite numbers"},
      {"NaN in the DOM", [](json& d) { d["objects"][1]["translate"] = {NAN, 0, 0}; },
       "scenes/t.json: objects[1].translate: expected three finite numbers"},
      {"float overflow", [](json& d) { d["lights"][0]["center"] = {0, 1e39, 0}; },
       "scenes/t.json: lights[0].center: expected three finite numbers"},
      {"two kinds", [](json& d) { d["objects"][0]["mesh"] = "x.obj"; },
       "scenes/t.json: objects[0]: expected exactly one of \"mesh\", \"shape\" or \"generator\""},
      {"no kind", [](json& d) { d["objects"][0] = {{"name", "x"}}; }, "scenes/t.json: objects[0]: expected exactly one"},
      {"unknown shape", [](json& d) { d["objects"][0]["shape"] = "cone"; }, "scenes/t.json: objects[0].shape: expected one of"},
      {"zero box size", [](json& d) { d["objects"][1]["size"] = {1, 0, 1}; },
       "scenes/t.json: objects[1].size: expected three positive numbers"},
      {"zero plane size", [](json& d) { d["objects"][0]["size"] = {0, 1}; },
       "scenes/t.json: objects[0].size: expected two positive numbers"},
      {"sphere segments", [](json& d) { d["objects"][1] = {{"shape", "sphere"}, {"radius", 1}, {"segments", 2}}; },
       "scenes/t.json: objects[1].segments: expected an integer in [3, 4096]"},
      {"zero scale", [](json& d) { d["objects"][1]["scale"] = 0; }, "scenes/t.json: objects[1].scale: expected a non-zero"},
      {"scale of wrong type", [](json& d) { d["objects"][1]["scale"] = "big"; }, "scenes/t.json: objects[1].scale: expected"},
      {"opacity above 1", [](json& d) { d["objects"][1]["material"] = {{"opacity", 1.5}}; },
       "scenes/t.json: objects[1].material.opacity: expected a number in [0, 1]"},
      {"albedo above 1", [](json& d) { d["objects"][1]["material"] = {{"albedo", {2, 0, 0}}}; },
       "scenes/t.json: objects[1].material.albedo: expected three numbers in [0, 1]"},
      {"unknown material key", [](json& d) { d["objects"][1]["material"] = {{"shiny", true}}; },
       "scenes/t.json: objects[1].material.shiny: unknown key"},
      {"two_sided not bool", [](json& d) { d["objects"][1]["material"] = {{"two_sided", 1}}; },
       "scenes/t.json: objects[1].material.two_sided: expected true or false"},
      {"missing mesh file", [](json& d) { d["objects"][1] = {{"mesh", "no/such/mesh.obj"}}; },
       "scenes/t.json: objects[1].mesh: scenes/no/such/mesh.obj: no such file"},
      {"empty mesh name", [](json& d) { d["objects"][1] = {{"mesh", ""}}; }, "scenes/t.json: objects[1].mesh: expected a file"},
      {"unknown generator", [](json& d) { d["objects"][1] = {{"generator", "teapot"}}; },
       "scenes/t.json: objects[1].generator: unknown generator \"teapot\" (available: "},
      {"generator param type", [](json& d) { d["objects"][1] = {{"generator", "plant"}, {"params", {{"leaves", "many"}}}}; },
       "scenes/t.json: objects[1].params.leaves: expected an integer"},
      {"generator param range", [](json& d) { d["objects"][1] = {{"generator", "plant"}, {"params", {{"leaves", -5}}}}; },
       "scenes/t.json: objects[1].params.leaves: expected an integer in [0, "},
      {"generator unknown param", [](json& d) { d["objects"][1] = {{"generator", "knot"}, {"params", {{"r", 1}}}}; },
       "scenes/t.json: objects[1].params.r: unknown key"},
      {"generator rejects params", [](json& d) { d["objects"][1] = {{"generator", "knot"}, {"params", {{"p", 2}, {"q", 4}}}}; },
       "scenes/t.json: objects[1].params: p and q must be coprime"},
      {"methods not objects", [](json& d) { d["methods"] = {{"lam", 64}}; }, "scenes/t.json: methods.lam: expected an object"},
      {"description not a string", [](json& d) { d["description"] = 1; }, "scenes/t.json: description: expected a string"},
      {"top level not an object", [](json& d) { d = json::array({1, 2}); }, "scenes/t.json: expected a JSON object"},
  };
  for (const auto& c : cases) {
    json d = minimal_doc();
    c.edit(d);
    std::string msg = error_message([&] { parse_scene(d, kOrigin); });
    EXPECT_NE(msg.find(c.expected), std::string::npos) << c.what << ": got \"" << msg << "\"";
    EXPECT_EQ(msg.find('\n'), std::string::npos) << c.what << ": message is not one line";
  }
}

TEST(SceneFile, RejectsBadJsonTextNamingFileAndPosition) {
  auto load_text = [](const std::string& text) {
    return error_message([&] { parse_scene(parse_json_text(text, kOrigin), kOrigin); });
  };
  std::string base = minimal_doc().dump(1);
  // nlohmann 3.11 refuses 1e400 while parsing (older versions made it inf, which
  // JsonValue rejects: see "infinite number in the DOM"); either way, the key is named.
  std::string huge = load_text(R"({"camera": {"eye": [0, 1e400, 5], "target": [0, 0, 0]},
    "lights": [{"type": "sphere", "center": [0, 3, 0], "radius": 1}],
    "objects": [{"shape": "box", "size": [1, 1, 1]}]})");
  EXPECT_EQ(huge, "scenes/t.json: camera.eye[1]: number out of range: 1e400");
  std::string syntax = load_text("{\n  \"camera\": {\n    \"eye\": [0, 1, 5],,\n");
  EXPECT_NE(syntax.find("scenes/t.json: invalid JSON: line 3, column"), std::string::npos) << syntax;
  EXPECT_EQ(syntax.find('\n'), std::string::npos);
  // A key of ill-formed UTF-8: the message quotes it as printable ASCII.
  std::string utf8 = load_text("{\"sc\xe5ne\": 0}");
  EXPECT_NE(utf8.find("scenes/t.json: invalid JSON: line 1, column"), std::string::npos) << utf8;
  EXPECT_NE(utf8.find("'\"sc?"), std::string::npos) << utf8;
  EXPECT_EQ(std::count_if(utf8.begin(), utf8.end(), [](char c) { return c < 32 || c >= 127; }), 0) << utf8;
  std::string dup = load_text(R"({"lights": [{"size": [1, 1]}, {"size": [1, 1], "size": [2, 2]}]})");
  EXPECT_EQ(dup, "scenes/t.json: lights[1].size: duplicate key");
  EXPECT_EQ(load_text(""), error_message([] { parse_json_text("", kOrigin); }));
  EXPECT_NE(load_text("").find("scenes/t.json: invalid JSON"), std::string::npos);
}

TEST(SceneFile, MissingSceneFile) {
  EXPECT_EQ(error_message([] { load_scene("/nonexistent/penumbra.json"); }), "/nonexistent/penumbra.json: no such file");
}

TEST(SceneFile, FinalizeOrientsSphereLightsAndFindsClosedObjects) {
  Scene s;
  AreaLight l;
  l.shape = LightShape::Sphere;
  l.center = {4, 0, 0};
  s.lights.push_back(l);
  s.finalize();  // no objects: points down
  expect_near(s.lights[0].frame.n, {0, -1, 0});
  SceneObject o;
  o.mesh.positions = {{-1, -1, -1}, {1, 1, 1}};
  s.objects.push_back(o);
  s.finalize();
  expect_near(s.lights[0].frame.n, {-1, 0, 0});
  EXPECT_FALSE(s.objects[0].closed);
}

// Every shipped scene loads (the suite the benchmarks and the README use).
TEST(SceneSuite, EveryShippedSceneLoads) {
  const fs::path dir = fs::path(PENUMBRA_SOURCE_DIR) / "scenes";
  ASSERT_TRUE(fs::is_directory(dir));
  int count = 0;
  const bool have_bunny = fs::exists("/usr/share/glmark2/models/bunny.obj");
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() != ".json") continue;
    std::string text = read_text_file(e.path());
    if (!have_bunny && text.find("glmark2") != std::string::npos) continue;
    SCOPED_TRACE(e.path().string());
    Scene s = load_scene(e.path());
    EXPECT_EQ(s.camera.width, 512);
    EXPECT_EQ(s.camera.height, 512);
    EXPECT_GT(s.triangle_count(), 0u);
    // A light large enough for wide penumbrae (AreaLight::diameter is in light.cpp, which
    // this layer does not own: the rect's diagonal by hand).
    ASSERT_EQ(s.lights[0].shape, LightShape::Rect);
    EXPECT_GE(std::hypot(s.lights[0].size.x, s.lights[0].size.y), 1.5f);
    ++count;
  }
  EXPECT_GE(count, have_bunny ? 6 : 4);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// Issue 20: material keys for textures, relative to the scene file's folder.
TEST(SceneFileTextures, AlphaAndAlbedoTexturesOnAPlane) {
  test::TempDir dir("scene_textures");
  Texture(2, 1, {0.05f, 0.05f, 0.05f, 1, 0.9f, 0.9f, 0.9f, 1}, false).write_png((dir / "mask.png").string());
  Texture(1, 1, {1, 0.5f, 0.25f, 0.5f}, true).write_png((dir / "base.png").string());
  json d = minimal_doc();
  d["objects"][0]["material"] = json::parse(R"({"alpha_texture": "mask.png", "alpha_cutoff": 0.4})");
  d["objects"][1] = json::parse(
      R"({"shape": "box", "size": [1, 1, 1], "material": {"albedo_texture": "base.png", "alpha_mode": "blend"}})");
  Scene s = parse_scene(d, dir / "t.json");
  const Material& plane = s.objects[0].material;
  EXPECT_EQ(plane.alpha.mode, AlphaMode::Mask);  // an alpha texture alone is a cut-out
  EXPECT_FLOAT_EQ(plane.alpha.cutoff, 0.4f);
  ASSERT_TRUE(plane.alpha_textured());
  EXPECT_FALSE(plane.alpha.texture->has_alpha());  // grey: its first channel
  // The left texel's byte is sRGB(0.05) = 63, read as data (a mask is linear): 0.25 < 0.4.
  EXPECT_EQ(plane.alpha.opacity({0.25f, 0.5f}), 0.0f);
  EXPECT_EQ(plane.alpha.opacity({0.75f, 0.5f}), 1.0f);
  EXPECT_EQ(s.objects[0].mesh.uvs.size(), 4u);
  const Material& box = s.objects[1].material;
  EXPECT_EQ(box.alpha.mode, AlphaMode::Blend);
  EXPECT_EQ(box.alpha.texture, box.albedo_texture);  // glTF's rule: the base colour's alpha
  EXPECT_NEAR(box.alpha.opacity({0.5f, 0.5f}), 0.5f, 0.01f);
  EXPECT_NEAR(box.albedo_at({0.5f, 0.5f}).x, 1.0f, 0.01f);  // albedo 1: the texture as it is
  EXPECT_NEAR(box.albedo_at({0.5f, 0.5f}).y, 0.5f, 0.01f);  // written sRGB-encoded, read decoded
  EXPECT_FALSE(s.objects[1].closed);  // a closed mesh with an alpha texture lets light through
}

TEST(SceneFileTextures, ErrorsNameTheKeyAndTheFile) {
  test::TempDir dir("scene_texture_errors");
  Texture(1, 1, {1, 1, 1, 1}, false).write_png((dir / "rgb.png").string());
  auto error_for = [&](const char* object) {
    json d = minimal_doc();
    d["objects"][0] = json::parse(object);
    return error_message([&] { parse_scene(d, dir / "t.json"); });
  };
  const std::string missing = error_for(R"({"shape": "plane", "size": [1, 1], "material": {"alpha_texture": "leaf.png"}})");
  EXPECT_NE(missing.find("objects[0].material.alpha_texture"), std::string::npos) << missing;
  EXPECT_NE(missing.find((dir / "leaf.png").string() + ": no such file"), std::string::npos) << missing;
  const std::string no_alpha =
      error_for(R"({"shape": "plane", "size": [1, 1], "material": {"albedo_texture": "rgb.png", "alpha_mode": "mask"}})");
  EXPECT_NE(no_alpha.find("alpha_mode"), std::string::npos) << no_alpha;
  EXPECT_NE(no_alpha.find("needs an \"alpha_texture\""), std::string::npos) << no_alpha;
  const std::string bad_mode = error_for(R"({"shape": "plane", "size": [1, 1], "material": {"alpha_mode": "clip"}})");
  EXPECT_NE(bad_mode.find("alpha_mode"), std::string::npos) << bad_mode;
  const std::string sphere = error_for(R"({"shape": "sphere", "radius": 1, "material": {"alpha_texture": "rgb.png"}})");
  EXPECT_NE(sphere.find("no texture coordinates"), std::string::npos) << sphere;
  const std::string cutoff =
      error_for(R"({"shape": "plane", "size": [1, 1], "material": {"alpha_texture": "rgb.png", "alpha_cutoff": 2}})");
  EXPECT_NE(cutoff.find("alpha_cutoff"), std::string::npos) << cutoff;
  for (const std::string& m : {missing, no_alpha, bad_mode, sphere, cutoff}) EXPECT_EQ(m.find('\n'), std::string::npos);
}

// Issue 32: leaf cards as they often arrive, the geometry from one tool (an OBJ with vt lines
// and no mtllib), the leaf image chosen in the scene file. The card at y = 1 has a mask whose
// left half (u < 0.5, x < 0) is a hole; a near-point light straight above; the camera below
// the card looks straight down at the ground (image right = +x). The ground under the hole is
// lit and under the solid half shadowed; without the mask both halves are shadowed.
TEST(SceneFileTextures, ObjWithVtAndNoMtllibTakesASceneAlphaTexture) {
  test::TempDir dir("scene_obj_uvs");
  Texture(2, 1, {1, 1, 1, 0, 1, 1, 1, 1}, true).write_png((dir / "mask.png").string());
  write_text_file_atomic(dir / "card.obj", "v -1 1 -1\nv 1 1 -1\nv 1 1 1\nv -1 1 1\n"
                                           "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 4/4 3/3\nf 1/1 3/3 2/2\n");
  json d = json::parse(R"({
    "camera": {"eye": [0, 0.5, 0], "target": [0, 0, 0], "up": [0, 0, -1], "fov_y": 60, "resolution": [32, 32]},
    "lights": [{"type": "rect", "center": [0, 4, 0], "normal": [0, -1, 0], "size": [0.01, 0.01]}],
    "objects": [{"shape": "plane", "size": [8, 8]},
                {"mesh": "card.obj", "material": {"alpha_texture": "mask.png"}}]})");
  const auto visibility = [&](const json& doc) {
    const Scene s = parse_scene(doc, dir / "t.json");
    RenderSettings settings;
    settings.method = "hard";
    return render_scene(s, settings).visibility;
  };
  const Image masked = visibility(d);
  EXPECT_GT(masked.at(6, 16), 0.99f);   // x < 0: under the hole
  EXPECT_LT(masked.at(25, 16), 0.01f);  // x > 0: under the solid half
  d["objects"][1].erase("material");
  const Image solid = visibility(d);
  EXPECT_LT(solid.at(6, 16), 0.01f);
  EXPECT_LT(solid.at(25, 16), 0.01f);
}

// A scene-file texture on a mesh file without texture coordinates: one line naming the scene
// key and the mesh file (OFF and STL carry none; an OBJ without vt lines has none).
TEST(SceneFileTextures, ATextureOnAMeshWithoutUvsNamesTheMeshFile) {
  test::TempDir dir("scene_no_uvs");
  Texture(1, 1, {1, 1, 1, 1}, true).write_png((dir / "mask.png").string());
  write_text_file_atomic(dir / "tri.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  write_text_file_atomic(dir / "tri.stl", "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                          "vertex 0 1 0\nendloop\nendfacet\nendsolid s\n");
  write_text_file_atomic(dir / "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  for (const char* mesh : {"tri.off", "tri.stl", "tri.obj"}) {
    for (const char* key : {"alpha_texture", "albedo_texture"}) {
      json d = minimal_doc();
      d["objects"][1] = {{"mesh", mesh}, {"material", {{key, "mask.png"}}}};
      const std::string msg = error_message([&] { parse_scene(d, dir / "t.json"); });
      EXPECT_EQ(msg, fmt::format("{}: objects[1].mesh: {}: has no texture coordinates, which the material's {} needs "
                                 "(an OBJ gives them with vt lines, a PLY with s,t or u,v, a glTF with TEXCOORD_0; "
                                 "OFF and STL files have none)",
                                 (dir / "t.json").string(), (dir / mesh).string(), key));
    }
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// Issue 20 part 3: "radiance_texture" on a rect light, relative to the scene file; an error on
// other light types and for a missing file.
TEST(SceneFileTextures, RadianceTextureOnARectLight) {
  test::TempDir dir("scene_light_texture");
  Texture(2, 1, {1, 0, 0, 1, 0, 0, 1, 1}, false).write_png((dir / "glass.png").string());
  json d = minimal_doc();
  d["lights"][0]["radiance_texture"] = "glass.png";
  d["lights"][0]["radiance"] = json::array({2, 2, 2});
  const Scene s = parse_scene(d, dir / "t.json");
  ASSERT_TRUE(s.lights[0].textured());
  EXPECT_NEAR(s.lights[0].texture->mean.x, 0.5f, 1e-3f);
  EXPECT_NEAR(s.lights[0].texture->mean.y, 0.0f, 1e-3f);
  EXPECT_EQ(expand_textured_lights(s.lights).size(), 2u);  // red and blue

  json disk = minimal_doc();
  disk["lights"][0] = json::parse(
      R"({"type": "disk", "center": [0, 3, 0], "normal": [0, -1, 0], "radius": 1, "radiance_texture": "glass.png"})");
  const std::string not_rect = error_message([&] { parse_scene(disk, dir / "t.json"); });
  EXPECT_NE(not_rect.find("lights[0].radiance_texture"), std::string::npos) << not_rect;
  EXPECT_NE(not_rect.find("only a rect light"), std::string::npos) << not_rect;
  d["lights"][0]["radiance_texture"] = "window.png";
  const std::string missing = error_message([&] { parse_scene(d, dir / "t.json"); });
  EXPECT_NE(missing.find((dir / "window.png").string() + ": no such file"), std::string::npos) << missing;
  // An EXR with an infinite texel: refused, naming the key, the file and the texel.
  Image hot(2, 1, 3, 1.0f);
  hot.at(1, 0, 2) = std::numeric_limits<float>::infinity();
  write_image((dir / "hot.exr").string(), hot);
  d["lights"][0]["radiance_texture"] = "hot.exr";
  const std::string infinite = error_message([&] { parse_scene(d, dir / "t.json"); });
  EXPECT_NE(infinite.find("lights[0].radiance_texture"), std::string::npos) << infinite;
  EXPECT_NE(infinite.find((dir / "hot.exr").string() + ": texel (1, 0) is not finite"), std::string::npos) << infinite;
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// The scene's material overrides a mesh file's alpha mode and keeps its alpha texture: an OBJ
// leaf card whose map_d makes a mask becomes a blend.
TEST(SceneFileTextures, SceneAlphaModeOverridesAMeshFilesAndKeepsItsTexture) {
  test::TempDir dir("scene_alpha_override");
  Texture(2, 1, {1, 1, 1, 0.25f, 1, 1, 1, 1}, true).write_png((dir / "mask.png").string());
  write_text_file_atomic(dir / "card.mtl", "newmtl leaf\nmap_d mask.png\n");
  write_text_file_atomic(dir / "card.obj",
                         "mtllib card.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                         "usemtl leaf\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n");
  json d = minimal_doc();
  d["objects"][1] = json::parse(R"({"mesh": "card.obj", "material": {"alpha_mode": "blend"}})");
  const Scene s = parse_scene(d, dir / "t.json");
  const Material& m = s.objects[1].material;
  EXPECT_EQ(m.alpha.mode, AlphaMode::Blend);
  ASSERT_TRUE(m.alpha_textured());
  EXPECT_NEAR(m.alpha.opacity({0.25f, 0.5f}), 0.25f, 0.01f);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
