// The viewer's server through real HTTP (cpp-httplib's client): frames equal the CLI's files
// bit for bit, bad requests get 400 and a one-line error, a newer view cancels stale work,
// and the preview/final workflow of docs/viewer.md.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <httplib.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "penumbra/core/image.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene/json_reader.h"
#include "penumbra/viewer/viewer_server.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/testing/gpu_method_runs.h"

namespace penumbra::viewer {
namespace {
namespace PENUMBRA_UNITY_ID {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// One poll answer, parsed (docs/viewer.md, "Frames").
struct Poll {
  json header;
  std::string pixels;
  // The layer's metadata, or null.
  json layer(const std::string& name) const {
    for (const json& l : header["layers"])
      if (l["name"] == name) return l;
    return nullptr;
  }
};

Poll parse_poll(const std::string& body) {
  Poll p;
  if (body.size() < 4) return p;
  uint32_t n = 0;
  for (int i = 0; i < 4; ++i) n |= static_cast<uint32_t>(static_cast<unsigned char>(body[i])) << (8 * i);
  p.header = json::parse(body.substr(4, n));
  p.pixels = body.substr(4 + n);
  return p;
}

class Viewer : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           fmt::format("penumbra-viewer-{}-{}", ::getpid(),
                       ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "meshes");
    // A tetrahedron beside the scene, named by a relative path (the saved scene makes it absolute).
    std::ofstream(dir_ / "meshes" / "tet.obj") << "v -0.3 0.2 -0.3\nv 0.3 0.2 -0.3\nv 0 0.2 0.3\nv 0 0.7 0\n"
                                                  "f 1 2 3\nf 1 4 2\nf 2 4 3\nf 3 4 1\n";
  }
  void TearDown() override {
    server_.reset();
    session_.reset();
    fs::remove_all(dir_);
  }

  // A box and the tetrahedron on a ground plane under a rect light, 40 x 40 pixels; or the
  // scene `text`.
  void start(SessionOptions options = {}, std::string bind = "127.0.0.1", std::string text = "") {
    if (text.empty()) text = R"({
      "camera": {"eye": [0, 3, 3], "target": [0, 0, 0], "fov_y": 40, "resolution": [40, 40]},
      "lights": [{"type": "rect", "center": [-0.3, 2.5, 0.2], "normal": [0.1, -1, 0], "size": [0.8, 0.8],
                  "radiance": [5, 5, 5]}],
      "objects": [{"name": "ground", "shape": "plane", "size": [6, 6]},
                  {"name": "box", "shape": "box", "size": [0.5, 0.5, 0.5], "translate": [0.5, 0.45, 0]},
                  {"name": "tet", "mesh": "meshes/tet.obj", "translate": [-0.6, 0, 0]}],
      "methods": {"pcss": {"blocker_samples": 16}}
    })";
    scene_path_ = dir_ / "scene.json";
    std::ofstream(scene_path_) << text;
    json doc = read_json_file(scene_path_);
    session_ = std::make_unique<ViewerSession>(parse_scene(doc, scene_path_), doc, options);
    ServerOptions so;
    so.bind = bind;
    so.port = 18600 + ::getpid() % 1000;
    server_ = std::make_unique<ViewerServer>(*session_, so);
    client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->port());
    client_->set_read_timeout(120, 0);
  }

  httplib::Result get(const std::string& path) { return client_->Get(path.c_str()); }
  httplib::Result post(const std::string& path, const std::string& body) {
    return client_->Post(path.c_str(), body, "application/json");
  }
  // Polls until `accept` holds for a poll answer or `seconds` pass; the last answer.
  Poll poll_until(const std::function<bool(const Poll&)>& accept, double seconds = 60) {
    const auto end = Clock::now() + std::chrono::duration<double>(seconds);
    Poll last;
    while (Clock::now() < end) {
      auto r = get(fmt::format("/api/poll?after={}&timeout_ms=2000", seq_));
      if (!r || r->status != 200) continue;
      last = parse_poll(r->body);
      seq_ = last.header["seq"].get<uint64_t>();
      if (accept(last)) return last;
    }
    ADD_FAILURE() << "no such frame within " << seconds << " s; last: " << last.header.dump();
    return last;
  }
  static bool final_done(const Poll& p, const std::string& layer = "main") {
    json l = p.layer(layer);
    return !l.is_null() && l["kind"] == "final" && l["frame"] == l["frames"];
  }

  fs::path dir_, scene_path_;
  std::unique_ptr<ViewerSession> session_;
  std::unique_ptr<ViewerServer> server_;
  std::unique_ptr<httplib::Client> client_;
  uint64_t seq_ = 0;
};

// The promise of GET /api/frame and of the saved scene: the CLI, given the scene the viewer
// saves and the same arguments, writes the very bytes /api/frame answers (after the light
// and the camera moved, with a method parameter set in the viewer).
TEST_F(Viewer, FrameEqualsTheCliRenderOfTheSavedSceneBitForBit) {
  start();
  auto moved = post("/api/view", R"({"camera": {"eye": [0.5, 2.8, 3.1]},
      "lights": [{"type": "rect", "center": [0.4, 2.2, -0.1], "normal": [-0.2, -1, 0.1], "size": [1.0, 0.6],
                  "radiance": [4, 5, 6]}]})");
  ASSERT_TRUE(moved);
  ASSERT_EQ(moved->status, 200) << moved->body;
  auto set = post("/api/settings", R"({"params": {"pcss": {"blocker_samples": 9}}})");
  ASSERT_EQ(set->status, 200) << set->body;
  auto saved = get("/api/scene-file");
  ASSERT_EQ(saved->status, 200);
  const json doc = json::parse(saved->body);
  EXPECT_TRUE(fs::path(doc["objects"][2]["mesh"].get<std::string>()).is_absolute());
  EXPECT_EQ(doc["methods"]["pcss"]["blocker_samples"], 9);
  // Saved elsewhere: the mesh is found through its absolute path.
  fs::create_directories(dir_ / "elsewhere");
  const fs::path saved_path = dir_ / "elsewhere" / "view.json";
  std::ofstream(saved_path) << saved->body;

  struct Case {
    std::string query, cli_args, ext;
  };
  const std::vector<Case> cases = {
      {"method=reference&spp=8&seed=3&format=png", "-m reference --spp 8 --seed 3", "png"},
      {"method=reference&spp=4&frames=3&format=exr", "-m reference --spp 4 --frames 3", "exr"},
      {"method=pcss&format=png", "-m pcss", "png"},
      {"method=afsm&spp=16&param=resolution=64&resolution=24x20&format=exr",
       "-m afsm --spp 16 -p resolution=64 --resolution 24x20", "exr"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.query);
    auto frame = get("/api/frame?" + c.query);
    ASSERT_TRUE(frame);
    ASSERT_EQ(frame->status, 200) << frame->body;
    EXPECT_EQ(frame->get_header_value("Content-Type"), c.ext == "png" ? "image/png" : "image/x-exr");
    const fs::path out = dir_ / ("cli." + c.ext);
    const std::string cmd =
        fmt::format("cd / && {} render {} {} -q -o {}", PENUMBRA_CLI, saved_path.string(), c.cli_args, out.string());
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    const std::string cli = slurp(out);
    ASSERT_FALSE(cli.empty());
    EXPECT_TRUE(frame->body == cli) << "the viewer's frame and the CLI's file differ (" << frame->body.size()
                                    << " vs " << cli.size() << " bytes)";
  }
}

// A scene file that leaves out every optional key: /api/state hands the page the camera and
// each light with every default filled in (the page reads no key a file may omit; issue 32),
// the scene's own keys as written, and the same after a patch that leaves keys out again.
TEST_F(Viewer, StateOfAMinimalSceneHasEveryDefaultFilledIn) {
  SessionOptions options;
  options.idle_ms = 100000;  // no refinement: only the state is looked at
  start(options, "127.0.0.1", R"({
    "camera": {"eye": [0, 3, 3], "target": [0, 0, 0]},
    "lights": [{"type": "rect", "center": [0, 2.5, 0], "normal": [0, -1, 0], "size": [0.8, 0.8]},
               {"type": "disk", "center": [1, 2.5, 0], "normal": [0, -1, 0.3], "radius": 0.3},
               {"type": "sphere", "center": [-1, 2.5, 0], "radius": 0.2},
               {"type": "ellipsoid", "center": [0, 2.5, 1], "normal": [0, -1, 0], "radii": [0.3, 0.2, 0.1]}],
    "objects": [{"shape": "plane", "size": [6, 6]}]
  })");
  const auto check = [](const json& st, const std::string& where) {
    SCOPED_TRACE(where);
    for (const json* camera : {&st["camera"], &st["initial"]["camera"]}) {
      for (std::string_view key : camera_keys()) EXPECT_TRUE(camera->contains(key)) << "camera." << key;
      EXPECT_EQ((*camera)["up"], json::array({0, 1, 0}));
      EXPECT_EQ((*camera)["fov_y"], 45);
      EXPECT_EQ((*camera)["resolution"], json::array({512, 512}));
      EXPECT_EQ((*camera)["samples_per_pixel"], 1);
    }
    for (const json* lights : {&st["lights"], &st["initial"]["lights"]}) {
      ASSERT_EQ(lights->size(), 4u);
      const LightShape shapes[] = {LightShape::Rect, LightShape::Disk, LightShape::Sphere, LightShape::Ellipsoid};
      for (size_t i = 0; i < 4; ++i)
        for (std::string_view key : light_keys(shapes[i]))
          if (key != "radiance_texture") EXPECT_TRUE((*lights)[i].contains(key)) << "lights[" << i << "]." << key;
      EXPECT_EQ((*lights)[0]["u"], json::array({1, 0, 0}));
      EXPECT_EQ((*lights)[0]["radiance"], json::array({1, 1, 1}));
    }
  };
  auto r = get("/api/state");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200);
  check(json::parse(r->body), "as loaded");
  // The saved scene stays as written: the defaults are the page's view, not the file's.
  EXPECT_FALSE(json::parse(get("/api/scene")->body)["camera"].contains("up"));
  auto moved = post("/api/view", R"({"camera": {"eye": [0.5, 3, 3]},
      "lights": [{"type": "rect", "center": [0, 2.4, 0], "normal": [0, -1, 0], "size": [0.8, 0.8]},
                 {"type": "disk", "center": [1, 2.5, 0], "normal": [0, -1, 0.3], "radius": 0.3},
                 {"type": "sphere", "center": [-1, 2.5, 0], "radius": 0.2},
                 {"type": "ellipsoid", "center": [0, 2.5, 1], "normal": [0, -1, 0], "radii": [0.3, 0.2, 0.1]}]})");
  ASSERT_EQ(moved->status, 200) << moved->body;
  const json st = json::parse(get("/api/state")->body);
  check(st, "after a patch");
  EXPECT_EQ(st["camera"]["eye"], json::array({0.5, 3, 3}));
  EXPECT_EQ(st["lights"][0]["center"], json::array({0, 2.4, 0}));
  // What the page sends back (the resolved lights, as it got them) is a valid view.
  auto same = post("/api/view", json{{"lights", st["lights"]}}.dump());
  ASSERT_EQ(same->status, 200) << same->body;
  EXPECT_EQ(json::parse(get("/api/state")->body)["lights"], st["lights"]);
}

// Every malformed request is answered 400 (or 403/404/405/413) with a one-line JSON error,
// changes nothing, and the server answers the next request as before.
TEST_F(Viewer, BadRequestsGet400WithAOneLineErrorAndChangeNothing) {
  start();
  const json before = json::parse(get("/api/state")->body);
  struct Bad {
    std::string method, path, body;
    int status;
    std::string mentions;
  };
  const std::vector<Bad> bad = {
      {"POST", "/api/view", "{", 400, "syntax error"},
      {"POST", "/api/view", "[1, 2]", 400, "expected a JSON object"},
      {"POST", "/api/view", R"({"camera": {"eye": [0, 1]}})", 400, "camera.eye"},
      {"POST", "/api/view", R"({"camera": {"eye": [0, 0, 0], "target": [0, 0, 0]}})", 400, "camera.target"},
      {"POST", "/api/view", R"({"camera": null})", 400, "camera"},
      {"POST", "/api/view", R"({"lights": []})", 400, "at least one light"},
      {"POST", "/api/view", R"({"lights": [{"type": "rect", "center": [0, 2, 0], "normal": [0, -1, 0], "size": [0, 1]}]})", 400, "lights[0].size"},
      {"POST", "/api/view", R"({"lights": [{"type": "sphere", "center": [0, 2, 0], "radius": 0.2, "normal": [0, 1, 0]}]})", 400, "lights[0].normal"},
      {"POST", "/api/view", R"({"camera": {"fov_y": 1e400}})", 400, "camera.fov_y"},
      {"POST", "/api/view", R"({"zoom": 2})", 400, "zoom"},
      {"POST", "/api/view", std::string(100, '[') + std::string(100, ']'), 400, "nested deeper"},
      {"POST", "/api/settings", R"({"final": "nope"})", 400, "unknown shadow method 'nope'"},
      {"POST", "/api/settings", R"({"spp": 0})", 400, "spp"},
      {"POST", "/api/settings", R"({"frames": 2.5})", 400, "frames"},
      {"POST", "/api/settings", R"({"params": {"pcss": {"blocker_samples": -3}}})", 400, "pcss.blocker_samples"},
      {"POST", "/api/settings", R"({"params": {"pcss": {"nope": 1}}})", 400, "unknown parameter 'nope'"},
      {"POST", "/api/settings", R"({"params": {"lam": {"resolution": 1e300}}})", 400, "lam.resolution"},
      {"POST", "/api/settings", R"({"preview_scale": 0})", 400, "preview_scale"},
      {"GET", "/api/frame?method=nope", "", 400, "method=\"nope\""},
      {"GET", "/api/frame?spp=-1", "", 400, "spp"},
      {"GET", "/api/frame?spp=12abc", "", 400, "spp"},
      {"GET", "/api/frame?frames=99999999999999999999", "", 400, "frames"},
      {"GET", "/api/frame?format=jpg", "", 400, "format"},
      {"GET", "/api/frame?resolution=0x10", "", 400, "resolution"},
      {"GET", "/api/frame?resolution=10x", "", 400, "resolution"},
      {"GET", "/api/frame?param=nokey", "", 400, "param"},
      {"GET", "/api/frame?param=nope=1&method=pcss", "", 400, "nope"},
      {"GET", "/api/frame?colour=red", "", 400, "unknown query key"},
      {"GET", "/api/poll?after=x", "", 400, "after"},
      {"GET", "/api/poll?timeout_ms=100000", "", 400, "timeout_ms"},
      {"GET", "/api/nothing", "", 404, "/api/nothing"},
      {"GET", "/api/view", "", 405, "POST"},
      {"POST", "/api/state", "{}", 405, "GET"},
      {"POST", "/api/view", std::string(2 << 20, ' '), 413, "too large"},
  };
  for (const Bad& b : bad) {
    SCOPED_TRACE(b.method + " " + b.path + " " + b.body.substr(0, 80));
    auto r = b.method == "GET" ? get(b.path) : post(b.path, b.body);
    ASSERT_TRUE(r) << httplib::to_string(r.error());
    EXPECT_EQ(r->status, b.status) << r->body;
    ASSERT_EQ(r->get_header_value("Content-Type"), "application/json");
    const json e = json::parse(r->body);
    const std::string message = e.value("error", "");
    EXPECT_NE(message.find(b.mentions), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos);
  }
  const json after = json::parse(get("/api/state")->body);
  EXPECT_EQ(after["generation"], before["generation"]);
  EXPECT_EQ(after["camera"], before["camera"]);
  EXPECT_EQ(after["lights"], before["lights"]);
  EXPECT_EQ(after["settings"], before["settings"]);
}

// Loopback only by default: a page of another site that reaches 127.0.0.1 through its own DNS
// name (rebinding) sends its own Host header, and is refused.
TEST_F(Viewer, ForeignHostHeadersAreRefused) {
  start();
  httplib::Headers foreign = {{"Host", "attacker.example:8421"}};
  auto r = client_->Get("/api/state", foreign);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 403);
  EXPECT_NE(json::parse(r->body)["error"].get<std::string>().find("attacker.example"), std::string::npos);
  EXPECT_EQ(get("/api/state")->status, 200);
  EXPECT_TRUE(is_loopback_address("127.0.0.1"));
  EXPECT_TRUE(is_loopback_address("::ffff:127.0.0.2"));
  EXPECT_TRUE(is_loopback_address("::1"));
  EXPECT_FALSE(is_loopback_address("192.168.1.4"));
  EXPECT_FALSE(is_loopback_address("0.0.0.0"));
  EXPECT_TRUE(is_loopback_host_header("localhost:8421"));
  EXPECT_TRUE(is_loopback_host_header("[::1]:8421"));
  EXPECT_TRUE(is_loopback_host_header("127.0.0.1"));
  EXPECT_FALSE(is_loopback_host_header("127.0.0.1.evil.example"));
  EXPECT_FALSE(is_loopback_host_header("[::1]x"));
  EXPECT_FALSE(is_loopback_host_header(""));
}

TEST_F(Viewer, ThePageAndTheMethodTableAreServed) {
  start();
  auto page = get("/");
  ASSERT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("viewer.js"), std::string::npos);
  EXPECT_EQ(get("/viewer.js")->status, 200);
  EXPECT_EQ(get("/viewer.css")->status, 200);
  const json methods = json::parse(get("/api/methods")->body);
  ASSERT_GE(methods.size(), 13u);
  bool lam = false;
  for (const json& m : methods)
    if (m["name"] == "lam") {
      lam = true;
      EXPECT_FALSE(m["params"].empty());
      EXPECT_TRUE(m["params"][0].contains("doc"));
    }
  EXPECT_TRUE(lam);
  const json scene = json::parse(get("/api/scene")->body);
  EXPECT_EQ(scene["objects"][2]["mesh"], "meshes/tet.obj");  // as in the file
}

// agrawala2000's workflow: a preview of the first view, then the final method refining to
// the frame `--frames K` gives; while the view is still, the auto preview measures every method
// on the session's device (preview_choice.h); a light move then previews with the method of
// least error whose measured time fits the frame-time target, and the frame says so.
TEST_F(Viewer, PreviewsWhileMovingAndRefinesToTheFramesRenderWhenStill) {
  SessionOptions options;
  // A poll gets the latest frame of each layer: the final frames of this tiny scene would
  // replace a preview before the test's next poll if they followed it at once.
  options.idle_ms = 1500;
  start(options);
  ASSERT_EQ(post("/api/settings", R"({"spp": 4, "frames": 3})")->status, 200);
  Poll done = poll_until([](const Poll& p) { return final_done(p); });
  const json main = done.layer("main");
  EXPECT_EQ(main["method"], "reference");
  // The last frame's pixels equal the render with --frames 3 to within rounding.
  Scene scene = load_scene(scene_path_);
  RenderSettings rs;
  rs.method = "reference";
  rs.light_samples = 4;
  rs.frames = 3;
  const std::vector<uint8_t> expected = to_rgba8(render_scene(scene, rs).color);
  const size_t offset = main["offset"].get<size_t>();
  ASSERT_GE(done.pixels.size(), offset + expected.size());
  int worst = 0;
  for (size_t i = 0; i < expected.size(); ++i)
    worst = std::max(worst, std::abs(int(static_cast<unsigned char>(done.pixels[offset + i])) - int(expected[i])));
  EXPECT_LE(worst, 1);

  // Still: every method is measured against the refined frame (or marked failed).
  json calibration;
  const auto end = Clock::now() + std::chrono::seconds(120);
  while (Clock::now() < end) {
    const json st = json::parse(get("/api/state")->body);
    if (st["status"]["phase"] == "done" && st["status"].contains("calibration")) {
      calibration = st["status"]["calibration"];
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(calibration.is_object()) << "the auto preview did not finish measuring";
  EXPECT_EQ(calibration.size(), MethodRegistry::all().size());
  // What the policy picks for a light move from those numbers.
  std::string expected_choice;
  double best = 1e300;
  for (const auto& [name, m] : calibration.items()) {
    if (m["failed"] || m["error"].is_null() || m["light_ms"].get<double>() > options.preview_target_ms) continue;
    if (m["error"].get<double>() < best) best = m["error"].get<double>(), expected_choice = name;
  }
  ASSERT_FALSE(expected_choice.empty()) << calibration.dump();

  // A light move: the preview is that method's, and the frame names the choice and its time.
  ASSERT_EQ(post("/api/view", R"({"lights": [{"type": "rect", "center": [0.3, 2.4, 0.2], "normal": [0, -1, 0],
                                   "size": [0.8, 0.8], "radiance": [5, 5, 5]}]})")->status, 200);
  Poll preview = poll_until([](const Poll& p) { return !p.layer("main").is_null() && p.layer("main")["kind"] == "preview"; });
  const json layer = preview.layer("main");
  EXPECT_EQ(layer["method"], expected_choice);
  EXPECT_EQ(layer["auto"]["method"], expected_choice);
  EXPECT_EQ(layer["auto"]["move"], "light");
  EXPECT_EQ(layer["auto"]["ms"], calibration[expected_choice]["light_ms"]);
  poll_until([](const Poll& p) { return final_done(p); });
  // A chosen preview method is used whatever moved.
  ASSERT_EQ(post("/api/settings", R"({"preview": "pcss"})")->status, 200);
  ASSERT_EQ(post("/api/view", R"({"camera": {"eye": [0.2, 3, 2.9]}})")->status, 200);
  Poll chosen = poll_until([](const Poll& p) { return !p.layer("main").is_null() && p.layer("main")["kind"] == "preview"; });
  EXPECT_EQ(chosen.layer("main")["method"], "pcss");
  EXPECT_TRUE(chosen.layer("main")["auto"].is_null());
}

// `penumbra view --map-cache DIR`: lam's maps, built once the view is still (the auto preview
// measures lam then), land in the folder, and a second session with the same scene reads them
// back instead of building them.
TEST_F(Viewer, MapCacheKeepsLamsMapsBetweenSessions) {
  SessionOptions options;
  options.map_cache = dir_ / "maps";
  start(options);
  ASSERT_EQ(post("/api/settings", R"({"spp": 4})")->status, 200);
  poll_until([](const Poll& p) { return final_done(p); });
  auto entries = [&] {
    int n = 0;
    for (const auto& e : fs::directory_iterator(options.map_cache)) n += e.path().extension() == ".map";
    return n;
  };
  auto measured = [&](const std::string& method) {
    const json st = json::parse(get("/api/state")->body);
    return st["status"].contains("calibration") && st["status"]["calibration"].contains(method);
  };
  auto end = Clock::now() + std::chrono::seconds(120);
  while (!(entries() > 0 && measured("lam")) && Clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_EQ(entries(), 1);
  const auto written = fs::last_write_time(*fs::directory_iterator(options.map_cache));
  server_.reset();
  session_.reset();
  seq_ = 0;  // the new session counts its frames from the start
  // The second session measures lam again: from the maps in the folder, not rebuilt.
  start(options);
  ASSERT_EQ(post("/api/settings", R"({"spp": 4})")->status, 200);
  poll_until([](const Poll& p) { return final_done(p); });
  end = Clock::now() + std::chrono::seconds(120);
  while (!measured("lam") && Clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_TRUE(measured("lam"));
  EXPECT_EQ(entries(), 1);
  EXPECT_EQ(fs::last_write_time(*fs::directory_iterator(options.map_cache)), written);  // read, not rewritten
}

// A newer view cancels the running refinement mid-render (CancelToken), and no frame of the
// old view is published after the change.
TEST_F(Viewer, ANewViewCancelsStaleWorkAtOnce) {
  SessionOptions options;
  options.idle_ms = 0;
  start(options);
  // A refinement that would run for minutes: many frames of many samples.
  ASSERT_EQ(post("/api/settings", R"({"spp": 4096, "frames": 100000})")->status, 200);
  Poll first = poll_until([](const Poll& p) {
    return !p.layer("main").is_null() && p.layer("main")["kind"] == "final";
  });
  const uint64_t old_generation = first.layer("main")["generation"].get<uint64_t>();
  const auto counters_before = session_->counters();
  const auto t0 = Clock::now();
  auto moved = post("/api/view", R"({"camera": {"eye": [0.4, 3, 3]}})");
  ASSERT_EQ(moved->status, 200);
  const uint64_t new_generation = json::parse(moved->body)["generation"].get<uint64_t>();
  EXPECT_GT(new_generation, old_generation);
  // The next frames are all of the new view.
  Poll next = poll_until([&](const Poll& p) {
    for (const json& l : p.header["layers"])
      EXPECT_GE(l["generation"].get<uint64_t>(), new_generation) << "a frame of the old view was published";
    // (The first frame of the new view: its preview, or already a final frame after it, since
    // a poll gets only the latest frame of a layer.)
    return !p.layer("main").is_null() && p.layer("main")["generation"].get<uint64_t>() >= new_generation;
  });
  const double preview_after_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  const auto counters_after = session_->counters();
  EXPECT_GE(counters_after.cancelled, counters_before.cancelled + 1);
  // One final frame of 4096 samples per pixel takes far longer than the cancellation, which
  // stops within one tile: the preview arrives before that frame could have finished.
  const double frame_ms = first.layer("main")["ms"].get<double>();
  EXPECT_LT(preview_after_ms, std::max(frame_ms, 2000.0) + 5000.0);
  EXPECT_TRUE(json::parse(get("/api/state")->body)["status"]["cancelled"].get<uint64_t>() >= 1);
}

// A compare method renders at the same view after the final frame, with the |dV| heat map
// and the mean |dV|.
TEST_F(Viewer, CompareGivesTheHeatMapAndMeanAbsoluteVisibilityError) {
  SessionOptions options;
  options.idle_ms = 0;
  start(options);
  ASSERT_EQ(post("/api/settings", R"({"final": "pcss", "spp": 16, "frames": 2})")->status, 200);
  poll_until([](const Poll& p) { return final_done(p) && p.layer("main")["method"] == "pcss"; });
  const uint64_t final_frames = session_->counters().final_frames;
  // Choosing a compare method keeps the finished final frame: only the comparison renders.
  ASSERT_EQ(post("/api/settings", R"({"compare": "reference"})")->status, 200);
  Poll diff = poll_until([](const Poll& p) { return !p.layer("diff").is_null(); });
  EXPECT_EQ(session_->counters().final_frames, final_frames);
  EXPECT_EQ(session_->counters().compare_frames, 2u);
  const json d = diff.layer("diff");
  ASSERT_TRUE(d["mean_dv"].is_number());
  EXPECT_GT(d["mean_dv"].get<double>(), 0.0);
  EXPECT_LT(d["mean_dv"].get<double>(), 0.5);
  EXPECT_EQ(d["heatmap"]["hi"], 0.25);
  EXPECT_EQ(d["width"], 40);
  // The mean |dV| is that of the two layers' visibility: check against renders of our own.
  Scene scene = load_scene(scene_path_);
  RenderSettings a, b;
  a.method = "pcss";
  a.light_samples = b.light_samples = 16;
  a.frames = b.frames = 2;
  b.method = "reference";
  const Image va = render_scene(scene, a).visibility, vb = render_scene(scene, b).visibility;
  double sum = 0;
  for (size_t i = 0; i < va.pixel_count(); ++i) sum += std::abs(va.data()[i] - vb.data()[i]);
  EXPECT_NEAR(d["mean_dv"].get<double>(), sum / va.pixel_count(), 1e-4);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::viewer

namespace penumbra::viewer {
namespace {
namespace PENUMBRA_UNITY_ID {

// `penumbra view --device gpu` (issue 30 part 2): every frame renders on the GPU, the state names
// the device, the methods offered are those with a GPU version, and the auto preview measures
// those on the GPU.
class ViewerOnGpu : public gpu::testing::GpuTest {};

TEST_F(ViewerOnGpu, ASessionOnTheGpuRendersThereAndOffersItsMethods) {
  const json doc = json::parse(R"({
    "camera": {"eye": [0, 3, 3], "target": [0, 0, 0], "fov_y": 40, "resolution": [32, 32]},
    "lights": [{"type": "rect", "center": [-0.3, 2.5, 0.2], "normal": [0.1, -1, 0], "size": [0.8, 0.8],
                "radiance": [5, 5, 5]}],
    "objects": [{"name": "ground", "shape": "plane", "size": [6, 6]},
                {"name": "box", "shape": "box", "size": [0.5, 0.5, 0.5], "translate": [0.5, 0.45, 0]}]
  })");
  SessionOptions options;
  options.device = gpu::DeviceChoice::parse("gpu");
  options.idle_ms = 50;
  ViewerSession session(parse_scene(doc, "gpu-view.json"), doc, options);
  EXPECT_EQ(session.state()["device"]["name"], device().info().name);
  EXPECT_EQ(session.state()["device"]["choice"], "gpu");
  for (const json& m : session.methods_json())
    EXPECT_EQ(m["available"].get<bool>(), find_gpu_method(m["name"]) != nullptr) << m["name"];
  // A method without a GPU version is refused in one line, and nothing changes.
  const std::string cpu_only = testing::cpu_only_method();
  if (!cpu_only.empty()) {
    try {
      session.update_settings(json{{"final", cpu_only}});
      FAIL() << "no error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(cpu_only + " has no GPU version"), std::string::npos) << e.what();
    }
  }
  session.update_settings(json{{"spp", 4}, {"frames", 2}});
  // The final frames, then the auto preview's measurements: only GPU methods, on the GPU.
  json calibration;
  const auto end = Clock::now() + std::chrono::seconds(120);
  while (Clock::now() < end) {
    const json st = session.state();
    if (st["status"]["phase"] == "done" && st["status"].contains("calibration")) {
      calibration = st["status"]["calibration"];
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_TRUE(calibration.is_object());
  EXPECT_GT(session.counters().final_frames, 0u);
  for (const auto& [name, m] : calibration.items()) {
    EXPECT_NE(find_gpu_method(name), nullptr) << name << " measured on a GPU session";
    EXPECT_FALSE(m["failed"].get<bool>()) << name;
  }
  EXPECT_TRUE(calibration.contains("reference"));
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::viewer
