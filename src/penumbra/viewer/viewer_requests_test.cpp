// The viewer's request parsing without a server: merge-patch semantics of views and
// settings, and that a refused request leaves nothing half-applied.
#include <gtest/gtest.h>

#include "penumbra/core/error.h"
#include "penumbra/scene/json_reader.h"
#include "penumbra/testing/test_scenes.h"
#include "penumbra/viewer/viewer_requests.h"

namespace penumbra::viewer {
namespace {
namespace PENUMBRA_UNITY_ID {

using nlohmann::json;

json scene_doc() {
  return json::parse(R"({
    "camera": {"eye": [0, 2, 4], "target": [0, 0, 0], "fov_y": 35, "resolution": [64, 48]},
    "lights": [{"type": "rect", "center": [0, 3, 0], "normal": [0, -1, 0], "size": [1, 1]},
               {"type": "sphere", "center": [2, 3, 0], "radius": 0.3}],
    "objects": [{"shape": "plane", "size": [4, 4]}]})");
}

Scene scene_of(const json& doc) { return parse_scene(doc, "test.json"); }

TEST(ViewerRequests, AViewPatchMergesTheCameraKeyByKeyAndReplacesTheLights) {
  const json doc = scene_doc();
  const Scene scene = scene_of(doc);
  const ViewState v0 = view_from_document(doc, scene);
  EXPECT_EQ(v0.parsed_camera.width, 64);
  bool camera = false, lights = false;
  ViewState v1 = apply_view_patch(v0, json::parse(R"({"camera": {"eye": [1, 2, 4]}})"), scene.bounds(), &camera, &lights);
  EXPECT_TRUE(camera);
  EXPECT_FALSE(lights);
  EXPECT_EQ(v1.parsed_camera.eye.x, 1.0f);
  EXPECT_EQ(v1.parsed_camera.fov_y, 35.0f);   // kept
  EXPECT_EQ(v1.parsed_camera.height, 48);     // kept
  // null removes a key: the scene format's default comes back.
  ViewState v2 = apply_view_patch(v1, json::parse(R"({"camera": {"fov_y": null}})"), scene.bounds());
  EXPECT_EQ(v2.parsed_camera.fov_y, Camera().fov_y);
  ViewState v3 = apply_view_patch(
      v2, json::parse(R"({"lights": [{"type": "sphere", "center": [0, 4, 0], "radius": 0.5}]})"), scene.bounds(),
      &camera, &lights);
  EXPECT_FALSE(camera);
  EXPECT_TRUE(lights);
  ASSERT_EQ(v3.parsed_lights.size(), 1u);
  // A sphere light faces the scene's centre, as when a scene file is loaded.
  EXPECT_NEAR(v3.parsed_lights[0].frame.n.y, -1.0f, 1e-6f);
  // The same view again changes nothing.
  apply_view_patch(v3, json::parse(R"({"camera": {"eye": [1, 2, 4]}})"), scene.bounds(), &camera, &lights);
  EXPECT_FALSE(camera);
  EXPECT_FALSE(lights);
}

TEST(ViewerRequests, ViewErrorsNameTheRequestAndTheKeyPath) {
  const json doc = scene_doc();
  const Scene scene = scene_of(doc);
  const ViewState v0 = view_from_document(doc, scene);
  try {
    apply_view_patch(v0, json::parse(R"({"lights": [{"type": "rect", "center": [0, 3], "normal": [0, -1, 0], "size": [1, 1]}]})"),
                     scene.bounds());
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("POST /api/view: lights[0].center: ", 0), 0u) << e.what();
  }
}

TEST(ViewerRequests, SettingsMergeParametersAndRefuseWhatTheMethodRefuses) {
  const json doc = scene_doc();
  const Scene scene = scene_of(doc);
  ViewerSettings s;
  s = apply_settings(s, json::parse(R"({"final": "afsm", "params": {"afsm": {"resolution": 256}}})"), scene);
  s = apply_settings(s, json::parse(R"({"params": {"afsm": {"lut": false}}})"), scene);
  EXPECT_EQ(s.final_method, "afsm");
  EXPECT_EQ(s.params["afsm"]["resolution"], 256);
  EXPECT_EQ(s.params["afsm"]["lut"], false);
  EXPECT_EQ(merged_method_params(scene, s)["afsm"]["resolution"], 256);
  s = apply_settings(s, json::parse(R"({"params": {"afsm": {"resolution": null}}})"), scene);
  EXPECT_FALSE(s.params["afsm"].contains("resolution"));
  EXPECT_EQ(apply_settings(s, json::parse(R"({"preview_scale": 0.5})"), scene).preview_scale, 0.5f);
  EXPECT_EQ(apply_settings(s, json::parse(R"({"preview_scale": "auto"})"), scene).to_json()["preview_scale"], "auto");
  EXPECT_THROW(apply_settings(s, json::parse(R"({"params": {"afsm": {"resolution": "big"}}})"), scene), Error);
  EXPECT_THROW(apply_settings(s, json::parse(R"({"params": {"nope": {}}})"), scene), Error);
  EXPECT_THROW(apply_settings(s, json::parse(R"({"compare": "nope"})"), scene), Error);
  EXPECT_EQ(apply_settings(s, json::parse(R"({"compare": ""})"), scene).compare, "");
}

TEST(ViewerRequests, FrameQueriesTakeTheSettingsAsDefaults) {
  ViewerSettings s;
  s.final_method = "pcss";
  s.spp = 12;
  FrameRequest r = parse_frame_request({}, s);
  EXPECT_EQ(r.method, "pcss");
  EXPECT_EQ(r.spp, 12);
  EXPECT_EQ(r.frames, 1);
  EXPECT_EQ(r.format, "png");
  r = parse_frame_request({{"method", "hard"}, {"resolution", "30x20"}, {"param", "bias=0.1"}, {"param", "x=2"},
                           {"seed", "7"}, {"format", "exr"}},
                          s);
  EXPECT_EQ(r.method, "hard");
  EXPECT_EQ(r.width, 30);
  EXPECT_EQ(r.height, 20);
  EXPECT_EQ(r.params, (std::vector<std::string>{"bias=0.1", "x=2"}));
  EXPECT_EQ(r.seed, 7u);
  EXPECT_THROW(parse_frame_request({{"resolution", "30x"}}, s), Error);
  r = parse_frame_request({{"resolution", "24"}}, s);
  EXPECT_EQ(r.width, 24);
  EXPECT_EQ(r.height, 24);
  EXPECT_THROW(parse_frame_request({{"resolution", "16385x2"}}, s), Error);
  EXPECT_THROW(parse_frame_request({{"seed", "-1"}}, s), Error);
}

TEST(ViewerRequests, QueryStringsSplitAtTheFirstEqualsSignAndDecodeEscapes) {
  const auto q = parse_query_string("/api/frame?method=pcss&param=bias=0.1&param=variant%3Dxie2007&x=a+b%21&flag&&#frag");
  ASSERT_EQ(q.size(), 5u);
  EXPECT_EQ(q.find("method")->second, "pcss");
  auto params = q.equal_range("param");
  std::vector<std::string> values;
  for (auto it = params.first; it != params.second; ++it) values.push_back(it->second);
  EXPECT_EQ(values, (std::vector<std::string>{"bias=0.1", "variant=xie2007"}));
  EXPECT_EQ(q.find("x")->second, "a b!");
  EXPECT_EQ(q.find("flag")->second, "");
  EXPECT_TRUE(parse_query_string("/api/state").empty());
  EXPECT_THROW(parse_query_string("/api/frame?a=%4"), Error);
  EXPECT_THROW(parse_query_string("/api/frame?a=%zz"), Error);
}

// A textured light (issue 20) in the viewer: its radiance_texture is found in the scene file's
// folder, when the view is read and after a patch that moves the light.
TEST(ViewerRequests, ATexturedLightsImageIsFoundBesideTheSceneFile) {
  const Scene scene = load_scene(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/stained-glass.json");
  const json doc = read_json_file(scene.source);
  const ViewState v0 = view_from_document(doc, scene);
  ASSERT_TRUE(v0.parsed_lights[0].textured());
  json moved = doc["lights"];
  moved[0]["center"] = json::array({-1.0, 3.0, -0.8});
  const ViewState v1 = apply_view_patch(v0, json{{"lights", moved}}, scene.bounds());
  ASSERT_TRUE(v1.parsed_lights[0].textured());
  EXPECT_EQ(v1.parsed_lights[0].center.x, -1.0f);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::viewer
