// End-to-end tests of `penumbra compare`, `sweep` and `bench`: the real binary on the
// contact scene at 32 x 32 pixels and a few light samples.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>

#include "penumbra/testing/compare_fixture.h"
#include "penumbra/testing/xml_check.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::slurp;

struct CliRun {
  int exit_code;
  std::string out, err;
};

class CliCompare : public ::testing::Test {
 protected:
  CliRun run(const std::string& args) {
    std::string out = (dir_ / "stdout.txt").string(), err = (dir_ / "stderr.txt").string();
    std::string cmd = fmt::format("cd {} && {} {} >{} 2>{}", PENUMBRA_SOURCE_DIR, PENUMBRA_CLI, args, out, err);
    int status = std::system(cmd.c_str());
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
  }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  testing::TempDir dir_;
};

TEST_F(CliCompare, CompareWritesThePageJsonCsvAndImages) {
  CliRun r = run(fmt::format("compare scenes/contact.json --methods reference,hard,single-sample --resolution 32 --spp 4 "
                          "--reference-spp 16 --cache-dir {} -o {} -p hard.bogus=1",
                          path("cache"), path("out")));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("hard                 failed: hard: unknown parameter 'bogus'"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("3 methods (1 failed), ground truth rendered"), std::string::npos) << r.err;
  for (const char* f : {"index.html", "results.json", "results.csv", "images/ground-truth.exr", "images/reference.exr",
                        "images/single-sample.exr"})
    EXPECT_TRUE(fs::exists(dir_ / "out" / f)) << f;
  EXPECT_FALSE(fs::exists(dir_ / "out" / "images" / "hard.exr"));
  // The equal-quality column in the summary, the error-time charts beside the page.
  EXPECT_NE(r.out.find("eq-speedup"), std::string::npos) << r.out;
  for (const char* f : {"error-time.svg", "flip-time.svg"}) EXPECT_TRUE(fs::exists(dir_ / "out" / f)) << f;
  json j = json::parse(slurp(dir_ / "out" / "results.json"));
  EXPECT_TRUE(j["reference_ladder"].is_object());
  EXPECT_NE(j["command"].get<std::string>().find("compare scenes/contact.json"), std::string::npos);
  EXPECT_EQ(j["spp"], 4);
  EXPECT_EQ(j["ground_truth"]["spp"], 16);
  EXPECT_FALSE(j["ground_truth"]["cached"].get<bool>());

  // Again: the ground truth comes from the cache.
  CliRun again = run(fmt::format("compare scenes/contact.json --methods hard --resolution 32 --reference-spp 16 "
                              "--cache-dir {} -o {} -q",
                              path("cache"), path("out2")));
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_TRUE(json::parse(slurp(dir_ / "out2" / "results.json"))["ground_truth"]["cached"].get<bool>());

  // With --objects: a table by object in the summary, the groups in results.json.
  CliRun objects = run(fmt::format("compare scenes/contact.json --methods hard --resolution 32 --reference-spp 16 "
                                   "--no-equal-quality --cache-dir {} -o {} --objects ground,'b*'",
                                   path("cache"), path("out3")));
  ASSERT_EQ(objects.exit_code, 0) << objects.err;
  EXPECT_NE(objects.out.find("mean |dV| (signed) by object:"), std::string::npos) << objects.out;
  const json j3 = json::parse(slurp(dir_ / "out3" / "results.json"));
  ASSERT_EQ(j3["object_groups"].size(), 2u);
  EXPECT_EQ(j3["object_groups"][1]["pattern"], "b*");
  EXPECT_EQ(j3["object_groups"][1]["objects"], 2);
  EXPECT_EQ(j3["methods"][0]["v_objects"].size(), 2u);
}

// Issue 32: the cache's images serve any thread count, its times only the thread count (and
// machine) that measured them. The summary says what each kind of speed-up divides and where
// that time comes from.
TEST_F(CliCompare, ACachedReferenceTimeServesOnlyItsOwnThreadCount) {
  struct Result {
    std::string summary, html;
    json results;
  };
  const auto compare = [&](int threads, const std::string& out) {
    CliRun r = run(fmt::format("compare scenes/contact.json --methods hard --resolution 24 --spp 4 --reference-spp 8 "
                               "--threads {} --cache-dir {} -o {}",
                               threads, path("cache"), path(out)));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return Result{r.out, slurp(dir_ / out / "index.html"), json::parse(slurp(dir_ / out / "results.json"))};
  };
  const auto expect_basis = [](const Result& r, const char* name, const char* text, bool cached) {
    EXPECT_EQ(r.results["ground_truth"]["cached"].get<bool>(), cached);
    EXPECT_EQ(r.results["ground_truth"]["time_basis"], name);
    EXPECT_EQ(r.results["speedup_basis_time"], name);
    EXPECT_TRUE(std::isfinite(r.results["methods"][0]["speedup"].get<double>()));
    for (const json& rung : r.results["reference_ladder"]["rungs"]) EXPECT_EQ(rung["time_basis"], name);
    EXPECT_NE(r.summary.find(fmt::format("speed-up over the ground truth's render at 8 light samples (time {})", text)),
              std::string::npos)
        << r.summary;
    EXPECT_NE(r.summary.find(fmt::format("light samples (times {})", text)), std::string::npos) << r.summary;
    EXPECT_NE(r.html.find(fmt::format("Reference time: {}.", text)), std::string::npos);
    EXPECT_NE(r.html.find(fmt::format("Reference times: {}.", text)), std::string::npos);
  };
  const char* now = "measured now";
  const char* here = "from the cache, same machine and threads";
  expect_basis(compare(2, "a"), "measured", now, false);
  expect_basis(compare(2, "b"), "cached_here", here, true);
  // Another thread count: the images from the cache, the times measured again...
  const Result c = compare(1, "c");
  expect_basis(c, "measured", now, true);
  for (const json& rung : c.results["reference_ladder"]["rungs"]) EXPECT_TRUE(rung["cached"].get<bool>());
  // ... and kept beside the first: both thread counts now find their own.
  expect_basis(compare(1, "d"), "cached_here", here, true);
  expect_basis(compare(2, "e"), "cached_here", here, true);
}

TEST_F(CliCompare, TwoComparesSharingOneCacheAtOnceBothSucceed) {
  // Two processes render the same ground truth into one fresh cache at the same time: both
  // finish, the cache holds one entry (EXR + meta) per key and no temporary file, and a third
  // run finds it. Entries are written to "<file>.tmp-<pid>" and renamed; the meta's checksum
  // ties it to its EXR.
  const std::string args = fmt::format("compare scenes/contact.json --methods hard --resolution 32 --reference-spp 64 "
                                       "--cache-dir {} -q",
                                       path("cache"));
  const std::string cmd = fmt::format(
      "cd {0} && {{ {1} {2} -o {3} >/dev/null 2>{3}.err & a=$!; {1} {2} -o {4} >/dev/null 2>{4}.err & b=$!; "
      "wait $a && wait $b; }}",
      PENUMBRA_SOURCE_DIR, PENUMBRA_CLI, args, path("a"), path("b"));
  const int status = std::system(("bash -c '" + cmd + "'").c_str());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << slurp(path("a") + ".err") << slurp(path("b") + ".err");
  for (const char* out : {"a", "b"}) {
    ASSERT_TRUE(fs::exists(dir_ / out / "results.json")) << out;
    EXPECT_TRUE(json::parse(slurp(dir_ / out / "results.json"))["ground_truth"].is_object());
  }
  int exr = 0, meta = 0;
  for (const auto& e : fs::directory_iterator(dir_ / "cache")) {
    const std::string name = e.path().filename().string();
    EXPECT_EQ(name.find(".tmp-"), std::string::npos) << name;
    // reference-<key>.exr and .json; the equal-quality ladder's rungs are reference-ladder-*.
    if (name.rfind("reference-ladder-", 0) == 0) continue;
    exr += e.path().extension() == ".exr";
    meta += e.path().extension() == ".json";
  }
  EXPECT_EQ(exr, 1);
  EXPECT_EQ(meta, 1);
  CliRun third = run(args + " -o " + path("c"));
  ASSERT_EQ(third.exit_code, 0) << third.err;
  EXPECT_TRUE(json::parse(slurp(dir_ / "c" / "results.json"))["ground_truth"]["cached"].get<bool>());
}

TEST_F(CliCompare, BadArgumentsAreOneLineErrors) {
  CliRun r = run("compare scenes/contact.json --methods hard,nosuch -o " + path("x"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("unknown shadow method 'nosuch'"), std::string::npos) << r.err;
  r = run("compare scenes/contact.json --methods hard -p light.sise=2 -o " + path("x"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("light.sise: unknown light setting"), std::string::npos) << r.err;
  r = run("sweep scenes/contact.json --method hard --param spp -o " + path("x"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("expected key=v1,v2,..."), std::string::npos) << r.err;
  r = run("sweep scenes/contact.json --param spp=1,2 -o " + path("x"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--method M or --methods"), std::string::npos) << r.err;
  r = run("sweep scenes/contact.json --method hard --param spp=1,2 --plot nope -o " + path("x"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--plot nope: unknown column"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "x"));
  // --objects: a pattern that names no object, or with --frame-range.
  r = run("compare scenes/contact.json --methods hard --objects ground,'leaf*' -o " + path("x"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--objects: 'leaf*' matches no object of the scene (its objects: ground, box, ball)"),
            std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "x"));
  std::ofstream(dir_ / "file") << "x";
  r = run("compare scenes/contact.json --methods hard --no-cache -o " + path("file"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("cannot create the output folder"), std::string::npos) << r.err;
}

TEST_F(CliCompare, FrameRangeWritesTheSequenceColumnsAndPlots) {
  // A tiny animated scene (issue 18): the camera moves over 3 frames.
  std::ofstream(dir_ / "walk.json") << testing::tiny_animated_contact_setup(3).scene_doc.dump(1);
  CliRun r = run(fmt::format("compare {} --frame-range 0:3 --methods hard,reference --resolution 24 --spp 2 "
                             "--reference-spp 16 --no-equal-quality --cache-dir {} -o {}",
                             path("walk.json"), path("cache"), path("out")));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("instability"), std::string::npos) << r.out;
  const std::string csv = slurp(dir_ / "out" / "results.csv");
  const std::string header = csv.substr(0, csv.find('\n'));
  EXPECT_NE(header.find(",temporal_instability,ms_per_frame_reuse,ms_per_frame_fresh"), std::string::npos) << header;
  json j = json::parse(slurp(dir_ / "out" / "results.json"));
  ASSERT_TRUE(j["frames"].is_object());
  EXPECT_EQ(j["frames"]["range"], json::array({0, 3}));
  ASSERT_EQ(j["frames"]["methods"].size(), 2u);
  for (const json& m : j["frames"]["methods"]) {
    EXPECT_EQ(m["v_mae"].size(), 3u);
    EXPECT_EQ(m["shadow_ms_reuse"].size(), 3u);
    EXPECT_TRUE(m["temporal_instability"].is_number());
    EXPECT_TRUE(m["ms_per_frame_fresh"].is_number());
  }
  const std::string html = slurp(dir_ / "out" / "index.html");
  EXPECT_NE(html.find("temporal instability"), std::string::npos);
  EXPECT_NE(html.find("<h2>Sequence</h2>"), std::string::npos);
  EXPECT_NE(html.find("mean |ΔV| per frame"), std::string::npos);
  // The sequence playable in the page: 3 frames of the ground truth and of each method.
  EXPECT_NE(html.find("id=\"seq-play\""), std::string::npos);
  const size_t data = html.find("window.penumbraSequence = {first: 0, fps: 24, frames: [[\"data:image/png;base64,");
  ASSERT_NE(data, std::string::npos);
  const std::string frames = html.substr(data, html.find("]};", data) - data);
  EXPECT_EQ(std::count(frames.begin(), frames.end(), '['), 1 + 3) << "the ground truth and 2 methods";
  size_t uris = 0;
  for (size_t p = frames.find("data:image/png"); p != std::string::npos; p = frames.find("data:image/png", p + 1)) ++uris;
  EXPECT_EQ(uris, 3u * 3u);
  for (const char* f : {"frames-error.svg", "frames-time.svg"}) EXPECT_TRUE(fs::exists(dir_ / "out" / f)) << f;
}

TEST_F(CliCompare, FrameRangeOnAStaticSceneIsAOneLineError) {
  CliRun r = run("compare scenes/contact.json --methods hard --frame-range 0:2 -o " + path("x"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--frame-range 0:2: scenes/contact.json has no \"animation\" block"), std::string::npos)
      << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "x"));
  std::ofstream(dir_ / "walk.json") << testing::tiny_animated_contact_setup(3).scene_doc.dump(1);
  r = run("compare " + path("walk.json") + " --methods hard --frame-range 2:5 -o " + path("x"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--frame-range"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "x"));
  r = run("compare " + path("walk.json") + " --methods hard --frame-range 0:2 --objects ground -o " + path("x"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--frame-range 0:2: not available with --objects"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "x"));
}

TEST_F(CliCompare, SweepWritesCsvAndPlots) {
  CliRun r = run(fmt::format("sweep scenes/contact.json --methods reference,hard --param spp=2,4,8 --resolution 24 "
                          "--no-reference --runs 2 --plot rays_traced -o {}",
                          path("sw")));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::string csv = slurp(dir_ / "sw" / "sweep.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 3 * 2);
  EXPECT_NE(csv.find("spp,8,8,reference,true,,8,"), std::string::npos) << csv;
  for (const char* f : {"time.svg", "rays.svg", "rays_traced.svg"}) {
    std::string problem;
    EXPECT_TRUE(testing::xml_well_formed(slurp(dir_ / "sw" / f), &problem)) << f << ": " << problem;
  }
  EXPECT_FALSE(fs::exists(dir_ / "sw" / "error.svg"));  // --no-reference
}

TEST_F(CliCompare, BenchWritesJsonAndMarkdown) {
  CliRun r = run(fmt::format("bench --scenes contact --methods hard --resolution 24 --spp 4 --runs 2 -o {}", path("b")));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  json j = json::parse(slurp(dir_ / "b" / "bench-results.json"));
  EXPECT_EQ(j["suite"], "quick (modified)");
  EXPECT_EQ(j["settings"]["runs"], 2);
  EXPECT_EQ(j["scenes"][0]["methods"].size(), 2u);
  EXPECT_DOUBLE_EQ(j["scenes"][0]["methods"][0]["speedup"].get<double>(), 1.0);
  std::string md = slurp(dir_ / "b" / "bench-results.md");
  EXPECT_NE(md.find("| `hard` |"), std::string::npos) << md;
  EXPECT_NE(r.out.find("| `hard` |"), std::string::npos) << r.out;  // the table on stdout too
}

TEST_F(CliCompare, BenchPerfSuiteErrorsAreOneLine) {
  CliRun r = run("bench --suite perf --spp 4 -o " + path("p"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--spp 4: the perf suite's targets fix their own light samples"), std::string::npos) << r.err;
  r = run("bench --suite perf --scenes contact -o " + path("p"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("none of the suite's targets is left after --methods and --scenes (targets on bunny, plant)"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  r = run("bench --suite slow -o " + path("p"));
  EXPECT_NE(r.exit_code, 0);  // CLI11's own exit code for a value not in the list
  EXPECT_NE(r.err.find("--suite"), std::string::npos) << r.err;
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
