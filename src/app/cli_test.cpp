// End-to-end tests of the `penumbra` tool: run the real binary on tiny scene files.
#include <gtest/gtest.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <httplib.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "penumbra/core/huge_pages.h"
#include "penumbra/core/image.h"
#include "penumbra/testing/cli_run.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

namespace fs = std::filesystem;

using testing::CliRun;

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / fmt::format("penumbra-cli-{}-{}", ::getpid(),
                                                   ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // `env`: variable assignments for the run ("PATH=/x").
  CliRun run(const std::string& args, const std::string& env = "") { return testing::run_cli(dir_, args, env); }
  static std::string slurp(const fs::path& p) { return testing::slurp(p); }
  std::string write(const std::string& name, const std::string& text) {
    fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  // A 1 x 1 occluder at height 1 over a ground plane, lit by a 0.5 x 0.5 rect light at
  // height 2: an umbra 0.5 wide surrounded by a penumbra.
  std::string tiny_scene(const std::string& extra_object_key = "") {
    return write("tiny.json", R"({
      "camera": {"eye": [0, 4, 0.001], "target": [0, 0, 0], "up": [0, 0, -1], "fov_y": 60, "resolution": [32, 24]},
      "lights": [{"type": "rect", "center": [0, 2, 0], "normal": [0, -1, 0], "u": [1, 0, 0],
                  "size": [0.5, 0.5], "radiance": [4, 4, 4]}],
      "objects": [
        {"shape": "plane", "size": [8, 8]},
        {"shape": "box", "size": [1, 0.05, 1], "translate": [0, 1, 0])" + extra_object_key + R"(}
      ]
    })");
  }
  // tiny_scene() animated over 3 frames: the occluder ("slab") slides and turns between
  // frames 0 and 1 and then stays; the camera and the light move on to frame 2. Every value
  // at frames 1 and 2 is exact in binary, so static scenes can give them (static_frame).
  std::string animated_tiny_scene() {
    nlohmann::json d = nlohmann::json::parse(slurp(tiny_scene(R"(, "name": "slab")")));
    d["animation"] = nlohmann::json::parse(R"({
      "frames": 3, "fps": 12,
      "camera": {"eye": [{"frame": 0, "value": [0, 4, 0.001]}, {"frame": 2, "value": [0.5, 4, 0.001]}]},
      "lights": {"0": {"center": [{"frame": 0, "value": [0, 2, 0]}, {"frame": 2, "value": [0.25, 2, 0]}]}},
      "objects": {"slab": {"translate": [{"frame": 0, "value": [0, 1, 0]}, {"frame": 1, "value": [0.25, 1, 0]}],
                           "rotate": {"interpolation": "catmull-rom",
                                      "keys": [{"frame": 0, "value": [0, 0, 0]}, {"frame": 1, "value": [0, 15, 0]}]}}}
    })");
    return write("anim.json", d.dump());
  }
  // The animated scene's frame 1 or 2 written as a static scene.
  std::string static_frame(int frame) {
    nlohmann::json d = nlohmann::json::parse(slurp(tiny_scene(R"(, "name": "slab")")));
    d["camera"]["eye"] = {0.25 * frame, 4, 0.001};
    d["lights"][0]["center"] = {0.125 * frame, 2, 0};
    d["objects"][1]["translate"] = {0.25, 1, 0};
    d["objects"][1]["rotate"] = {0, 15, 0};
    return write(fmt::format("static{}.json", frame), d.dump());
  }
  fs::path dir_;
};

// --map-cache: the second run reads lam's maps (no precompute), writes the same pixels, and
// says so in --stats-json; a file in the folder's place is a one-line error naming it.
TEST_F(Cli, RenderMapCacheSecondRunReadsTheMaps) {
  const std::string scene = tiny_scene();
  const fs::path cache = dir_ / "maps";
  std::vector<nlohmann::json> stats;
  for (int run_index = 0; run_index < 2; ++run_index) {
    const fs::path exr = dir_ / fmt::format("lam{}.exr", run_index), json = dir_ / fmt::format("lam{}.json", run_index);
    CliRun r = run(fmt::format("render {} -m lam --spp 16 -p resolution=64 --map-cache {} -o {} --stats-json {} --quiet",
                               scene, cache.string(), exr.string(), json.string()));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    stats.push_back(nlohmann::json::parse(slurp(json)));
  }
  EXPECT_EQ(stats[0]["map_cache"]["misses"], 1);
  EXPECT_EQ(stats[1]["map_cache"]["hits"], 1);
  EXPECT_EQ(stats[1]["stats"]["prepare_count"], 0);
  EXPECT_EQ(stats[1]["map_cache"]["entries"], 1);
  EXPECT_EQ(slurp(dir_ / "lam0.exr"), slurp(dir_ / "lam1.exr"));

  const fs::path file = dir_ / "file";
  std::ofstream(file) << "x";
  CliRun bad = run(fmt::format("render {} -m lam --map-cache {} -o {} --quiet", scene, file.string(),
                               (dir_ / "x.png").string()));
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.err.find("--map-cache " + file.string() + ": exists and is not a folder"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(dir_ / "x.png"));
}

// The command line re-executes itself with glibc's heap on 2 MiB pages where the kernel offers
// them (core/huge_pages.h), and --stats-json says whether it ran so. A user's own
// glibc.malloc.hugetlb, or PENUMBRA_HUGE_PAGES=0, is obeyed; another tunable is kept.
TEST_F(Cli, TheHeapIsOnHugePagesWhereTheKernelOffersThem) {
  const std::string scene = tiny_scene();
  const fs::path exr = dir_ / "out.exr", stats = dir_ / "stats.json";
  auto huge_pages = [&](const std::string& env) {
    CliRun r = run(fmt::format("render {} -m hard -o {} --stats-json {} --quiet", scene, exr.string(), stats.string()),
                   env);
    EXPECT_EQ(r.exit_code, 0) << env << ": " << r.err;
    return nlohmann::json::parse(slurp(stats)).at("huge_pages").get<bool>();
  };
  const bool available = huge_pages_available();
  EXPECT_EQ(huge_pages("env -u GLIBC_TUNABLES"), available);
  EXPECT_EQ(huge_pages("GLIBC_TUNABLES=glibc.malloc.perturb=0"), available);
  EXPECT_FALSE(huge_pages("GLIBC_TUNABLES=glibc.malloc.hugetlb=0"));
  EXPECT_FALSE(huge_pages("env -u GLIBC_TUNABLES PENUMBRA_HUGE_PAGES=0"));
}

TEST_F(Cli, RenderWritesAnImageWithSoftShadows) {
  std::string scene = tiny_scene();
  fs::path exr = dir_ / "out.exr", stats = dir_ / "stats.json";
  CliRun r = run(fmt::format("render {} -m reference --spp 64 -o {} --stats-json {} --quiet", scene, exr.string(),
                          stats.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  Image v = read_exr_channel(exr.string(), "V");
  EXPECT_EQ(v.width(), 32);
  EXPECT_EQ(v.height(), 24);
  int umbra = 0, penumbra = 0, lit = 0;
  for (float x : v.data()) {
    ASSERT_GE(x, 0.0f);
    ASSERT_LE(x, 1.0f);
    umbra += x < 0.02f;
    penumbra += x > 0.05f && x < 0.95f;
    lit += x > 0.999f;
  }
  EXPECT_GT(umbra, 0);
  EXPECT_GT(penumbra, 0);
  EXPECT_GT(lit, 0);
  auto j = nlohmann::json::parse(slurp(stats));
  EXPECT_EQ(j["method"], "reference");
  EXPECT_GT(j["stats"]["rays_traced"].get<uint64_t>(), 0u);

  fs::path png = dir_ / "out.png";
  ASSERT_EQ(run(fmt::format("render {} -m hard -o {} --resolution 16x8 --quiet", scene, png.string())).exit_code, 0);
  Image img = read_image(png.string());
  EXPECT_EQ(img.width(), 16);
  EXPECT_EQ(img.height(), 8);
  // N alone is N x N, as compare and sweep take it.
  ASSERT_EQ(run(fmt::format("render {} -m hard -o {} --resolution 12 --quiet", scene, png.string())).exit_code, 0);
  img = read_image(png.string());
  EXPECT_EQ(img.width(), 12);
  EXPECT_EQ(img.height(), 12);
}

TEST_F(Cli, RenderAccumulatesFramesAndBendsNormals) {
  std::string scene = tiny_scene();
  fs::path one = dir_ / "one.exr", four = dir_ / "four.exr", stats = dir_ / "stats.json";
  ASSERT_EQ(run(fmt::format("render {} -m afsm --spp 64 -o {} --quiet", scene, one.string())).exit_code, 0);
  CliRun r = run(fmt::format("render {} -m afsm --spp 64 --frames 4 --coherent-shading -o {} --stats-json {} --quiet",
                             scene, four.string(), stats.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto j = nlohmann::json::parse(slurp(stats));
  EXPECT_EQ(j["frames"], 4);
  EXPECT_EQ(j["coherent_shading"], true);
  // Each frame draws new light samples: the average differs from one frame.
  EXPECT_NE(read_exr_channel(one.string(), "V").data(), read_exr_channel(four.string(), "V").data());
  // Bad values are one-line errors naming the value.
  r = run(fmt::format("render {} -m afsm --spp 2000 -o {} --quiet", scene, one.string()));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("2000"), std::string::npos) << r.err;
  EXPECT_NE(run(fmt::format("render {} -m afsm --frames 0 -o {} --quiet", scene, one.string())).exit_code, 0);
}

TEST_F(Cli, RenderCropWritesTheWindowOfTheWholeImage) {
  std::string scene = tiny_scene();
  fs::path whole = dir_ / "whole.exr", crop = dir_ / "crop.exr";
  const std::string common = fmt::format("render {} -m reference --spp 16 --pixel-samples 2 --seed 5 --quiet", scene);
  ASSERT_EQ(run(fmt::format("{} -o {}", common, whole.string())).exit_code, 0);
  CliRun r = run(fmt::format("{} --crop 5,3,22,17 -o {}", common, crop.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Image whole_rgb = read_image(whole.string()), crop_rgb = read_image(crop.string());
  const Image whole_v = read_exr_channel(whole.string(), "V"), crop_v = read_exr_channel(crop.string(), "V");
  ASSERT_EQ(crop_rgb.width(), 17);
  ASSERT_EQ(crop_rgb.height(), 14);
  ASSERT_EQ(crop_v.width(), 17);
  ASSERT_EQ(crop_v.height(), 14);
  // The window cut out of the whole image, value for value (the umbra lies inside it).
  float v_min = 1.0f;
  for (int y = 0; y < 14; ++y)
    for (int x = 0; x < 17; ++x) {
      ASSERT_EQ(crop_v.at(x, y), whole_v.at(x + 5, y + 3)) << x << "," << y;
      for (int c = 0; c < 3; ++c) ASSERT_EQ(crop_rgb.at(x, y, c), whole_rgb.at(x + 5, y + 3, c)) << x << "," << y;
      v_min = std::min(v_min, crop_v.at(x, y));
    }
  EXPECT_LT(v_min, 0.1f);
  // Bad windows are one-line errors naming --crop, and write nothing.
  fs::path never = dir_ / "never.exr";
  for (const char* bad : {"1,2,3", "5,3,5,17", "a,b,c,d", "0,0,33,24", "-1,0,3,4"}) {
    r = run(fmt::format("render {} -m hard --crop {} -o {} --quiet", scene, bad, never.string()));
    EXPECT_NE(r.exit_code, 0) << bad;
    EXPECT_NE(r.err.find("--crop"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(never));
  }
  r = run(fmt::format("render {} -m hard --crop 0,0,33,24 -o {} --quiet", scene, never.string()));
  EXPECT_NE(r.err.find("outside the 32x24 image"), std::string::npos) << r.err;
}

TEST_F(Cli, FrameRangeRendersEachFrameAsTheSceneAtThatFrame) {
  const std::string scene = animated_tiny_scene();
  const fs::path stats = dir_ / "stats.json";
  const std::string common = "-m reference --spp 16 --pixel-samples 2 --seed 3 --quiet";
  CliRun r = run(fmt::format("render {} {} --frame-range 0:3 -o {} --stats-json {}", scene, common,
                             (dir_ / "frame_####.exr").string(), stats.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (int f = 0; f < 3; ++f) EXPECT_TRUE(fs::exists(dir_ / fmt::format("frame_{:04d}.exr", f))) << f;
  EXPECT_FALSE(fs::exists(dir_ / "frame_0003.exr"));
  // Frame 1 (the slab moved: refit in the Embree scene) and frame 2 (the same renderer, given
  // the new camera and light) equal renders of the scene at those frames written as static
  // scenes.
  for (int f : {1, 2}) {
    const fs::path single = dir_ / fmt::format("static{}.exr", f);
    ASSERT_EQ(run(fmt::format("render {} {} -o {}", static_frame(f), common, single.string())).exit_code, 0);
    const std::string frame = (dir_ / fmt::format("frame_{:04d}.exr", f)).string();
    EXPECT_EQ(read_image(frame).data(), read_image(single.string()).data()) << f;
    EXPECT_EQ(read_exr_channel(frame, "V").data(), read_exr_channel(single.string(), "V").data()) << f;
  }
  EXPECT_NE(read_image((dir_ / "frame_0000.exr").string()).data(), read_image((dir_ / "frame_0001.exr").string()).data());
  // The stats: one object per frame, saying which frame built the renderer and which moved
  // objects (the slab, refit).
  const auto j = nlohmann::json::parse(slurp(stats));
  ASSERT_TRUE(j.is_array());
  ASSERT_EQ(j.size(), 3u);
  for (int f = 0; f < 3; ++f) {
    EXPECT_EQ(j[f]["frame"], f);
    EXPECT_EQ(j[f]["method"], "reference");
    EXPECT_EQ(j[f]["new_renderer"], f == 0) << f;
    EXPECT_EQ(j[f]["moved_objects"], f == 1 ? 1 : 0) << f;
    EXPECT_EQ(j[f]["refit"], f == 1) << f;
  }
  // --frames K (progressive accumulation) keeps its meaning in each frame.
  r = run(fmt::format("render {} -m afsm --spp 16 --frames 2 --quiet --frame-range 1:2 -o {} --stats-json {}", scene,
                      (dir_ / "acc_#.exr").string(), stats.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(slurp(stats))[0]["frames"], 2);
  EXPECT_TRUE(fs::exists(dir_ / "acc_1.exr"));
}

TEST_F(Cli, FrameRangePatternsAndForms) {
  const std::string scene = animated_tiny_scene();
  // The run of # is the frame number, zero-padded to its length.
  CliRun r = run(fmt::format("render {} -m hard --quiet --frame-range 1: -o {} --visibility-out {}", scene,
                             (dir_ / "c_###_x.png").string(), (dir_ / "v#.png").string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* name : {"c_001_x.png", "c_002_x.png", "v1.png", "v2.png"}) EXPECT_TRUE(fs::exists(dir_ / name)) << name;
  EXPECT_FALSE(fs::exists(dir_ / "c_000_x.png"));
  ASSERT_EQ(run(fmt::format("render {} -m hard --quiet --frame-range :2 -o {}", scene, (dir_ / "d#.png").string()))
                .exit_code, 0);
  EXPECT_TRUE(fs::exists(dir_ / "d0.png"));
  EXPECT_TRUE(fs::exists(dir_ / "d1.png"));
  EXPECT_FALSE(fs::exists(dir_ / "d2.png"));
  // Without progress output a sequence prints one summary line.
  r = run(fmt::format("render {} -m hard --frame-range 0:3 -o {}", scene, (dir_ / "e##.png").string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("frames 0:3 (3, objects moved in 1, refit)"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(dir_ / "e02.png"));
}

TEST_F(Cli, FrameRangeErrorsNameTheOptionAndWriteNothing) {
  const std::string scene = animated_tiny_scene(), still = tiny_scene();
  const std::string out = (dir_ / "f_####.png").string();
  struct Case {
    std::string args, expected;
  };
  const std::vector<Case> cases = {
      {fmt::format("render {} --frame-range 0:1 -o {}", still, out),
       fmt::format("--frame-range 0:1: {} has no \"animation\" block", still)},
      {fmt::format("render {} --frame-range 2:1 -o {}", scene, out),
       "--frame-range 2:1: expected A:B, the frames A to B-1 with 0 <= A < B <= 3"},
      {fmt::format("render {} --frame-range 0:4 -o {}", scene, out), "--frame-range 0:4: expected A:B"},
      {fmt::format("render {} --frame-range 1 -o {}", scene, out), "--frame-range 1: expected A:B"},
      {fmt::format("render {} --frame-range 0:2 -o {}", scene, (dir_ / "f.png").string()),
       "f.png: a frame sequence needs a run of # for the frame number"},
      {fmt::format("render {} --frame-range 0:2 -o {}", scene, (dir_ / "f_##_#.png").string()),
       "f_##_#.png: more than one run of #"},
      {fmt::format("render {} --frame-range 0:2", scene), "--frame-range 0:2: give -o out/frame_####.exr"},
      {fmt::format("render {} --frame-range 0:2 -o {} --visibility-out {}", scene, out, (dir_ / "v.png").string()),
       "--visibility-out"},
      {fmt::format("render {} --frame-range 0:2 -o {} --dask tcp://localhost:8786", scene, out),
       "--frame-range 0:2: not available with --dask"},
      {fmt::format("render {} --frame-range 0:2 -o {}", scene, (dir_ / "no" / "f_#.png").string()), "does not exist"},
  };
  for (const Case& c : cases) {
    CliRun r = run(c.args);
    EXPECT_EQ(r.exit_code, 1) << c.args;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.args << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  for (const auto& e : fs::directory_iterator(dir_)) EXPECT_NE(e.path().extension(), ".png") << e.path();
}

TEST_F(Cli, FrameRangeEncodesAnMp4WithFfmpeg) {
  const std::string scene = animated_tiny_scene();
  const fs::path movie = dir_ / "movie.mp4";
  // Without ffmpeg on PATH: one line naming it, before the scene is even read.
  fs::create_directories(dir_ / "empty");
  CliRun r = run(fmt::format("render {} -o {}", (dir_ / "missing.json").string(), movie.string()),
                 "PATH=" + (dir_ / "empty").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("movie.mp4: writing an MP4 needs ffmpeg, which is not on PATH"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(movie));

  if (std::system("command -v ffmpeg >/dev/null 2>&1") != 0) GTEST_SKIP() << "ffmpeg is not installed";
  // An odd size: yuv420p needs even sides, so the frames are padded.
  r = run(fmt::format("render {} -m hard --resolution 31x23 --quiet -o {}", scene, movie.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_TRUE(fs::exists(movie));
  EXPECT_GT(fs::file_size(movie), 0u);
  for (const auto& e : fs::directory_iterator(dir_)) EXPECT_EQ(e.path().string().find(".tmp-"), std::string::npos);
  if (std::system("command -v ffprobe >/dev/null 2>&1") == 0) {
    const fs::path count = dir_ / "count.txt";
    ASSERT_EQ(std::system(fmt::format("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
                                      "stream=nb_read_frames,width,height -of csv=p=0 {} >{}",
                                      movie.string(), count.string())
                              .c_str()),
              0);
    EXPECT_EQ(slurp(count), "32,24,3\n");
  }
  // A range of the frames; a scene without an animation has none to encode.
  r = run(fmt::format("render {} -m hard --resolution 16 --quiet --frame-range 1:3 -o {}", scene, movie.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run(fmt::format("render {} -m hard --quiet -o {}", tiny_scene(), (dir_ / "still.mp4").string()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("-o " + (dir_ / "still.mp4").string() + ": "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("has no \"animation\" block"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "still.mp4"));
}

TEST_F(Cli, BadSceneIsOneLineErrorNamingFileAndKeyAndWritesNothing) {
  std::string scene = tiny_scene(R"(, "colour": [1, 0, 0])");
  fs::path out = dir_ / "never.png";
  CliRun r = run(fmt::format("render {} -o {}", scene, out.string()));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("tiny.json"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("colour"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(Cli, DeeplyNestedJsonIsOneLineErrorNotACrash) {
  // 100,000 levels of brackets once overflowed the stack (printing the value for a message);
  // the parser now refuses nesting deeper than kMaxJsonDepth while it reads, in a scene
  // file and in a -p value alike.
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  fs::path out = dir_ / "never.png";
  for (const std::string& scene : {write("nested.json", deep), write("nested_camera.json", "{\"camera\": " + deep + "}")}) {
    CliRun r = run(fmt::format("render {} -o {}", scene, out.string()));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("nested deeper than 64 levels"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(".json"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
  CliRun r = run(fmt::format("scene plant --param leaves={} -o {}", std::string(5000, '[') + std::string(5000, ']'),
                             (dir_ / "never.json").string()));
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("--param leaves: nested deeper than 64 levels"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "never.json"));
}

// Starts the tool with `args` (no shell), its stdout and stderr going to the given files.
pid_t spawn_cli(const std::vector<std::string>& args, const std::string& stdout_path, const std::string& stderr_path) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    std::vector<char*> argv;
    std::string cli = PENUMBRA_CLI;
    argv.push_back(cli.data());
    std::vector<std::string> copy = args;
    for (std::string& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (std::freopen(stderr_path.c_str(), "w", stderr) == nullptr) ::_exit(127);
    if (std::freopen(stdout_path.c_str(), "w", stdout) == nullptr) ::_exit(127);
    ::execv(PENUMBRA_CLI, argv.data());
    ::_exit(127);
  }
  return pid;
}

// Starts the tool with `args`, lets it run `before`, sends `sig` and returns (exit code,
// seconds from the signal to the exit); the exit code is -1 if it had not ended 10 s after
// the signal (it is then killed).
std::pair<int, double> interrupt_after(const std::vector<std::string>& args, std::chrono::milliseconds before, int sig,
                                       const std::string& stderr_path) {
  const pid_t pid = spawn_cli(args, "/dev/null", stderr_path);
  std::this_thread::sleep_for(before);
  ::kill(pid, sig);
  const auto sent = std::chrono::steady_clock::now();
  int status = 0;
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() - sent > std::chrono::seconds(10)) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      return {-1, 10.0};
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - sent).count();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, seconds};
}

// Within a second; ThreadSanitizer's build (scripts/tsan.sh) runs some ten times slower and
// its exit alone takes a few tenths of a second, so it gets three.
#if defined(__SANITIZE_THREAD__)
constexpr double kInterruptSeconds = 3.0;
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
constexpr double kInterruptSeconds = 3.0;
#else
constexpr double kInterruptSeconds = 1.0;
#endif
#else
constexpr double kInterruptSeconds = 1.0;
#endif

TEST_F(Cli, CtrlCStopsWithinASecondAndLeavesNothing) {
  // A render that would take many seconds, and a comparison (its ground truth being
  // rendered into a fresh cache), interrupted: exit 130 with one line, well within a second
  // (the watchdog's limit), no output file, no temporary file, no cache entry.
  const std::string scene = std::string(PENUMBRA_SOURCE_DIR) + "/scenes/contact.json";
  const fs::path out = dir_ / "out.exr";
  const fs::path cache = dir_ / "cache", cmp = dir_ / "cmp";
  const std::vector<std::vector<std::string>> runs = {
      {"render", scene, "-m", "reference", "--spp", "65536", "-o", out.string()},
      {"compare", scene, "--methods", "hard", "--reference-spp", "65536", "--cache-dir", cache.string(), "-o",
       cmp.string()},
  };
  for (int sig : {SIGINT, SIGTERM})
    for (const auto& args : runs) {
      SCOPED_TRACE(args[0] + (sig == SIGINT ? " SIGINT" : " SIGTERM"));
      const auto [code, seconds] = interrupt_after(args, std::chrono::milliseconds(1500), sig, (dir_ / "err.txt").string());
      const std::string err = slurp(dir_ / "err.txt");
      EXPECT_EQ(code, 130) << err;
      EXPECT_LT(seconds, kInterruptSeconds);
      EXPECT_NE(err.find("interrupted"), std::string::npos) << err;
      EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
      EXPECT_FALSE(fs::exists(out));
      EXPECT_FALSE(fs::exists(cmp / "index.html"));
      for (const auto& e : fs::recursive_directory_iterator(dir_)) {
        EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
        if (e.is_regular_file()) EXPECT_NE(e.path().extension(), ".exr") << e.path();
      }
    }
}

TEST_F(Cli, RendersTooLargeForMemoryAreRefusedUpFront) {
  // 16384^2 with 4 camera samples: about 30 GiB of view samples, refused before anything is
  // allocated (at once, whatever the method and its samples), naming the settings to lower.
  const std::string scene = tiny_scene();
  const fs::path out = dir_ / "never.exr";
  CliRun r = run(fmt::format("render {} -m mlsm --spp 1024 --resolution 16384x16384 --pixel-samples 4 -o {}", scene,
                             out.string()));
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("tiny.json: a 16384x16384 image with 4 camera sample(s) per pixel needs about"),
            std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(80% of physical memory); lower camera.resolution"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(out));
  // An explicit limit: the 32 x 24 scene needs about 100 KiB.
  r = run(fmt::format("render {} -m hard --memory-limit 10K -o {}", scene, out.string()));
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("over the memory limit of 10 KiB; lower"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  r = run(fmt::format("render {} -m hard --memory-limit 1G -q -o {}", scene, out.string()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out));
  r = run(fmt::format("render {} -m hard --memory-limit lots -o {}", scene, (dir_ / "x.exr").string()));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "penumbra: error: --memory-limit lots: expected a size in bytes, or with K, M, G or T (e.g. 8G)\n");
}

TEST_F(Cli, MethodMapsTooLargeForMemoryAreRefusedUpFront) {
  const std::string scene = tiny_scene();
  const fs::path out = dir_ / "never.exr";
  // Refused with exit 1 and one line holding `expected`, before anything is written.
  auto expect_refused = [&](const std::string& args, const std::string& expected) {
    SCOPED_TRACE(args);
    const CliRun r = run(fmt::format("render {} {} -o {}", scene, args, out.string()));
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find(expected), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(out));
  };
  // A 32 x 24 image (about 100 KiB of view samples) whose method would build about 7 GiB of
  // occlusion textures (4096^2 texels, 32 slices, 13 N-buffer levels, and 2 GiB of the slices'
  // nearest depths): refused before anything is allocated, naming the parameter to lower.
  expect_refused("-m occlusion-textures -p resolution=4096 -p slices=32 --memory-limit 64M",
                 "tiny.json: occlusion-textures needs about 7.2 GiB for its light-space data (and 102 KiB for the "
                 "view samples), over the memory limit of 64.0 MiB; lower -p occlusion-textures.resolution or raise "
                 "--memory-limit");
  // mlsm's layered map: 8192^2 texels of 64 layers (about 64 GiB).
  expect_refused("-m mlsm -p resolution=8192 -p layers=64 --memory-limit 1G",
                 "lower -p mlsm.resolution or raise --memory-limit");
  // What grows with the light samples names --spp: the reference's per-thread buffers at
  // 2^20 samples (40 MiB a thread).
  expect_refused("-m reference --spp 1048576 --threads 1 --memory-limit 16M", "lower --spp or raise --memory-limit");
  // The same method at a sensible size fits the same limit.
  const CliRun r = run(fmt::format("render {} -m occlusion-textures -p resolution=256 --memory-limit 64M -q -o {}",
                                   scene, out.string()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out));
}

TEST_F(Cli, BadArgumentsAreRejected) {
  std::string scene = tiny_scene();
  CliRun r = run(fmt::format("render {} -m no-such-method -o {}", scene, (dir_ / "x.png").string()));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("no-such-method"), std::string::npos) << r.err;
  r = run(fmt::format("render {} -p samples=3 -o {}", scene, (dir_ / "x.png").string()));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("samples"), std::string::npos) << r.err;
  r = run(fmt::format("render {} -o {}", scene, (dir_ / "x.bmp").string()));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find(".bmp"), std::string::npos) << r.err;
  r = run(fmt::format("render {} --resolution 0x5 -o {}", scene, (dir_ / "x.png").string()));
  EXPECT_NE(r.exit_code, 0);
  r = run(fmt::format("render {} -o {}", (dir_ / "missing.json").string(), (dir_ / "x.png").string()));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("missing.json"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "x.png"));
}

TEST_F(Cli, DiffMeasuresVisibilityErrorAndWritesAHeatmap) {
  std::string scene = tiny_scene();
  std::string ref = (dir_ / "ref.exr").string(), hard = (dir_ / "hard.exr").string();
  ASSERT_EQ(run(fmt::format("render {} -m reference --spp 64 -o {} -q", scene, ref)).exit_code, 0);
  ASSERT_EQ(run(fmt::format("render {} -m hard -o {} -q", scene, hard)).exit_code, 0);
  // An image against itself: no error at all.
  CliRun same = run(fmt::format("diff {} {} --json", ref, ref));
  ASSERT_EQ(same.exit_code, 0) << same.err;
  auto js = nlohmann::json::parse(same.out);
  EXPECT_EQ(js["on"], "v");
  EXPECT_EQ(js["mae"].get<double>(), 0.0);
  // Hard shadows against the reference: the MAE on V equals the mean |dV| computed here.
  std::string heat = (dir_ / "heat.png").string();
  CliRun d = run(fmt::format("diff {} {} --json --heatmap {}", hard, ref, heat));
  ASSERT_EQ(d.exit_code, 0) << d.err;
  auto j = nlohmann::json::parse(d.out);
  Image a = read_exr_channel(hard, "V"), b = read_exr_channel(ref, "V");
  double mae = 0;
  for (size_t i = 0; i < a.data().size(); ++i) mae += std::abs(a.data()[i] - b.data()[i]);
  mae /= a.data().size();
  EXPECT_GT(mae, 0.01);
  EXPECT_NEAR(j["mae"].get<double>(), mae, 1e-6);
  Image h = read_image(heat);
  EXPECT_EQ(h.width(), a.width());
  // Colour mode reports FLIP too.
  CliRun c = run(fmt::format("diff {} {} --on color --json", hard, ref));
  ASSERT_EQ(c.exit_code, 0) << c.err;
  EXPECT_GT(nlohmann::json::parse(c.out)["flip"].get<double>(), 0.0);
  // Mismatched sizes are an error naming both.
  std::string small = (dir_ / "small.exr").string();
  ASSERT_EQ(run(fmt::format("render {} -m hard --resolution 8x8 -o {} -q", scene, small)).exit_code, 0);
  CliRun bad = run(fmt::format("diff {} {}", small, ref));
  EXPECT_NE(bad.exit_code, 0);
}

TEST_F(Cli, MethodsListsEveryRegisteredMethod) {
  CliRun r = run("methods");
  ASSERT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("reference"), std::string::npos);
  EXPECT_NE(r.out.find("hard"), std::string::npos);
  r = run("methods reference");
  ASSERT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("sampling"), std::string::npos);
}

// `penumbra view` as a process: it prints where it serves (the next free port when the asked
// one is taken), answers, and stops cleanly on Ctrl-C even with a long poll open.

// The exit code, or -1 when the process had not ended after `limit` (it is killed then).
int wait_exit(pid_t pid, std::chrono::duration<double> limit, double* seconds) {
  const auto start = std::chrono::steady_clock::now();
  int status = 0;
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() - start > limit) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string read_text(const fs::path& p) {
  std::ifstream f(p);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

TEST(CliView, ServesOnTheNextFreePortAndStopsOnCtrlCWithAPollOpen) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("penumbra-cli-view-{}", ::getpid());
  fs::remove_all(dir);
  fs::create_directories(dir);
  // The asked-for port is taken by another listener.
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  int taken = 0;
  for (int p = 19300 + ::getpid() % 500; p < 19900 && !taken; ++p) {
    addr.sin_port = htons(static_cast<uint16_t>(p));
    if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0 && ::listen(fd, 1) == 0) taken = p;
  }
  ASSERT_NE(taken, 0);
  const std::string scene = std::string(PENUMBRA_SOURCE_DIR) + "/scenes/contact.json";
  const fs::path out = dir / "out.txt", err = dir / "err.txt";
  const pid_t pid = spawn_cli({"view", scene, "--no-browser", "--port", std::to_string(taken)}, out.string(), err.string());
  std::smatch m;
  std::string text;
  static const std::regex serving("penumbra view: serving http://127\\.0\\.0\\.1:([0-9]+)/\n");
  for (auto end = std::chrono::steady_clock::now() + std::chrono::seconds(60); std::chrono::steady_clock::now() < end;) {
    text = read_text(out);
    if (std::regex_search(text, m, serving)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(std::regex_search(text, m, serving)) << text << read_text(err);
  const int port = std::stoi(m[1]);
  EXPECT_GT(port, taken);
  httplib::Client client("127.0.0.1", port);
  auto state = client.Get("/api/state");
  ASSERT_TRUE(state);
  EXPECT_EQ(state->status, 200);
  EXPECT_EQ(nlohmann::json::parse(state->body)["camera"]["resolution"][0], 512);
  // A long poll (nothing newer than a huge seq), open while the server is asked to stop.
  std::thread poller([port] {
    httplib::Client c("127.0.0.1", port);
    c.set_read_timeout(40, 0);
    c.Get("/api/poll?after=1000000000&timeout_ms=30000");
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ::kill(pid, SIGINT);
  double seconds = 0;
  const int code = wait_exit(pid, std::chrono::seconds(10), &seconds);
  poller.join();
  ::close(fd);
  const std::string e = read_text(err);
  EXPECT_EQ(code, 0) << e;
  EXPECT_LT(seconds, 1.0);
  EXPECT_NE(e.find("penumbra view: stopped"), std::string::npos) << e;
  EXPECT_EQ(e.find("interrupted"), std::string::npos) << e;
  fs::remove_all(dir);
}

TEST(CliView, ASceneThatDoesNotLoadIsOneLineAndExit1) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("penumbra-cli-view-bad-{}", ::getpid());
  fs::create_directories(dir);
  std::ofstream(dir / "bad.json") << R"({"camera": {"eye": [0, 1, 2], "target": [0, 0, 0]}, "lights": [], "objects": []})";
  const fs::path out = dir / "out.txt", err = dir / "err.txt";
  double seconds = 0;
  const int code = wait_exit(spawn_cli({"view", (dir / "bad.json").string(), "--no-browser"}, out.string(), err.string()),
                             std::chrono::seconds(30), &seconds);
  const std::string e = read_text(err);
  EXPECT_EQ(code, 1);
  EXPECT_NE(e.find("bad.json: lights: expected at least one light"), std::string::npos) << e;
  EXPECT_EQ(std::count(e.begin(), e.end(), '\n'), 1) << e;
  EXPECT_TRUE(read_text(out).empty());
  fs::remove_all(dir);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
