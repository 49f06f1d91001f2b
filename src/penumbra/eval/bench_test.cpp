#include "penumbra/eval/bench.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>

#include "penumbra/core/error.h"
#include "penumbra/scene/json_reader.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/testing/compare_fixture.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using nlohmann::json;

BenchSuite tiny_suite() {
  BenchSuite s = bench_suite("quick", std::string(PENUMBRA_SOURCE_DIR) + "/scenes");
  s.name = "test";
  s.scenes = {std::string(PENUMBRA_SOURCE_DIR) + "/scenes/contact.json"};
  s.resolution = 24;
  s.light_samples = 4;
  s.runs = 3;
  s.warmup_runs = 1;
  return s;
}

TEST(Bench, SuitesAreDefined) {
  BenchSuite q = bench_suite("quick", "scenes"), f = bench_suite("full", "scenes");
  EXPECT_EQ(q.scenes.size(), 5u);
  EXPECT_EQ(q.resolution, 128);
  EXPECT_EQ(f.resolution, 512);
  EXPECT_EQ(f.light_samples, 256);
  EXPECT_GE(f.runs, 3);
  EXPECT_THROW(bench_suite("huge", "scenes"), Error);
  EXPECT_TRUE(q.targets.empty());
  // Issues 32 and 34: the bunny, the 25-tree forest, the street and the 100-tree forest (its file
  // is the generator's scene at trees = 100), at issue 34's settings, with errors.
  BenchSuite w = bench_suite("wide", std::string(PENUMBRA_SOURCE_DIR) + "/scenes");
  ASSERT_EQ(w.scenes.size(), 4u);
  EXPECT_EQ(w.scenes[0].stem(), "bunny");
  EXPECT_EQ(w.scenes[1].stem(), "forest");
  EXPECT_EQ(w.scenes[2].stem(), "street");
  EXPECT_EQ(w.scenes[3].stem(), "forest-100");
  EXPECT_EQ(w.resolution, 256);
  EXPECT_EQ(w.light_samples, 256);
  EXPECT_EQ(w.reference_spp, 1024);
  const json doc = read_json_file(w.scenes[3]);
  EXPECT_EQ(doc["objects"][1]["generator"], "forest");
  EXPECT_EQ(doc["objects"][1]["params"]["trees"], 100);
  for (const auto& f : w.scenes) EXPECT_TRUE(std::filesystem::exists(f)) << f;
  EXPECT_EQ(q.reference_spp, 0);
  // Where the error lives: the ground and the casters of the bunny and both forests.
  using Groups = std::vector<std::pair<std::string, std::vector<std::string>>>;
  EXPECT_EQ(w.object_groups, (Groups{{"bunny", {"ground", "bunny"}},
                                     {"forest", {"ground", "*.leaves"}},
                                     {"forest-100", {"ground", "*.leaves"}}}));
  EXPECT_TRUE(q.object_groups.empty());
}

// A suite with errors and object groups: every method's error over each group's pixels, in the
// JSON (by pattern) and in a table of the Markdown. The ground truth goes to a cache of its own.
TEST(Bench, ObjectGroupsGiveEachMethodsErrorWhereItLives) {
  testing::TempDir dir;
  // The ground truth's cache for this test alone, the variable as it was afterwards.
  struct CacheDir {
    const char* old = std::getenv("PENUMBRA_CACHE_DIR");
    std::string saved = old ? old : "";
    explicit CacheDir(const std::string& path) { setenv("PENUMBRA_CACHE_DIR", path.c_str(), 1); }
    ~CacheDir() {
      if (old) setenv("PENUMBRA_CACHE_DIR", saved.c_str(), 1);
      else unsetenv("PENUMBRA_CACHE_DIR");
    }
  } cache_dir((dir / "cache").string());
  BenchOptions o;
  o.suite = tiny_suite();
  o.suite.reference_spp = 16;
  o.suite.runs = 1;
  o.suite.warmup_runs = 0;
  o.suite.object_groups = {{"contact", {"ground", "b*"}}};
  o.methods = {"hard"};
  const json r = run_bench(o);
  const json& scene = r["scenes"][0];
  ASSERT_EQ(scene["object_groups"].size(), 2u) << scene.dump();
  EXPECT_EQ(scene["object_groups"][1]["pattern"], "b*");
  EXPECT_EQ(scene["object_groups"][1]["objects"], 2);  // the box and the ball
  for (const json& m : scene["methods"]) {
    ASSERT_TRUE(m.contains("v_objects")) << m.dump();
    for (const char* pattern : {"ground", "b*"}) EXPECT_TRUE(m["v_objects"][pattern]["v_mae"].is_number()) << m.dump();
  }
  const std::string md = bench_markdown(r);
  EXPECT_NE(md.find("By object: "), std::string::npos) << md;
  EXPECT_NE(md.find("| contact: `ground` ("), std::string::npos) << md;
  EXPECT_NE(md.find("| contact: `b*` ("), std::string::npos) << md;
}

// The wide-scene line (issue 34 part 4): each later scene's error and time as multiples of the
// first scene's, and "worse than hard" where a method's error exceeds hard's there.
TEST(Bench, TheWideSceneLineComparesEachSceneWithTheFirst) {
  auto method = [](const char* name, double ms, double mae) {
    return json{{"method", name}, {"ok", true}, {"shadow_ms", ms}, {"v_mae", mae}};
  };
  json doc = {{"suite", "wide"},
              {"settings", {{"resolution", 256}, {"spp", 256}, {"runs", 1}, {"warmup_runs", 0}, {"reference_spp", 1024}}},
              {"machine", {{"cpu", "test"}, {"threads", 2}}},
              {"methods", {"hard", "lam"}},
              {"scenes",
               {{{"name", "bunny"}, {"methods", {method("hard", 10, 0.03), method("lam", 100, 0.007)}}},
                {{"name", "forest"}, {"methods", {method("hard", 40, 0.045), method("lam", 1500, 0.1)}}}}}};
  const std::string md = bench_markdown(doc);
  EXPECT_NE(md.find("| `hard` | error 1.50×, time 4.00× |"), std::string::npos) << md;
  EXPECT_NE(md.find("| `lam` | error 14.3×, time 15.0×, **worse than hard** |"), std::string::npos) << md;
  // Without errors (the other suites) there is no such line.
  doc["settings"]["reference_spp"] = 0;
  EXPECT_EQ(bench_markdown(doc).find("Against `bunny`"), std::string::npos);
}

// The perf suite lists the targets of issue 14 part 2, no more and no fewer (not a timing test).
TEST(Bench, PerfSuiteListsTheTargetsOfTheIssue) {
  BenchSuite p = bench_suite("perf", "scenes");
  EXPECT_EQ(p.resolution, 256);  // the ratio targets' default
  ASSERT_EQ(p.scenes.size(), 2u);
  EXPECT_EQ(p.scenes[0].stem(), "bunny");
  EXPECT_EQ(p.scenes[1].stem(), "plant");
  EXPECT_GE(p.runs, 3);
  using K = PerfTarget::Kind;
  // (method, scene, light samples, resolution, kind, measure, goal)
  using Row = std::tuple<std::string, std::string, int, int, K, std::string, double>;
  std::vector<Row> expected;
  for (std::string scene : {"bunny", "plant"}) {
    expected.push_back({"afsm", scene, 1024, 0, K::kSpeedup, "shadow_ms", 2.0});
    expected.push_back({"afsm", scene, 256, 0, K::kSpeedup, "shadow_ms", 1.0});
    for (std::string m : {"mlsm", "mtsm", "coherent-rt", "multi-view-sm"})
      expected.push_back({m, scene, 256, 0, K::kSpeedup, "shadow_ms", 1.0});
  }
  expected.push_back({"lam", "bunny", 64, 512, K::kTime, "phase:display", 5.0});
  expected.push_back({"lam", "bunny", 64, 512, K::kTime, "phase:precompute", 500.0});
  for (std::string m : {"hard", "shadow-map", "pcss", "single-sample", "occlusion-textures"})
    expected.push_back({m, "bunny", 256, 512, K::kTime, "total_ms", 16.0});
  std::vector<Row> listed;
  for (const PerfTarget& t : p.targets) {
    listed.push_back({t.method, t.scene, t.light_samples, t.resolution, t.kind, t.measure, t.goal});
    EXPECT_NO_THROW(MethodRegistry::get(t.method)) << t.method;  // a registered method
    // lam's targets time the paper's display (no point traced); the others run as shipped.
    EXPECT_EQ(t.params, t.method == "lam" ? std::vector<std::string>{"lam.unresolved=umbra"} : std::vector<std::string>{});
  }
  EXPECT_EQ(listed, expected);
  EXPECT_EQ(perf_target_label(p.targets[0], 256), "afsm, 1024 spp, bunny 256²: speed-up over reference ≥ 2×");
  EXPECT_EQ(perf_target_label(p.targets.back(), 256), "occlusion-textures, 256 spp, bunny 512²: whole frame < 16 ms");
  EXPECT_EQ(perf_target_label(p.targets[12], 256), "lam, 64 spp, bunny 512², lam.unresolved=umbra: display < 5 ms");
}

TEST(Bench, TargetsArePassedOrMissedFromOneInterleavedRun) {
  using K = PerfTarget::Kind;
  BenchOptions o;
  o.suite = tiny_suite();
  o.suite.resolution = 16;
  o.suite.runs = 3;
  o.suite.warmup_runs = 0;
  o.suite.targets = {
      {"hard", "contact", 4, 0, K::kSpeedup, "shadow_ms", 1e-9, {}},          // surely met
      {"single-sample", "contact", 4, 0, K::kSpeedup, "shadow_ms", 1e9, {}},  // surely missed
      {"hard", "contact", 4, 20, K::kTime, "total_ms", 1e9, {}},              // its own resolution
      {"hard", "contact", 4, 20, K::kTime, "phase:nope", 1, {}},              // no such phase
      {"hard", "bunny", 4, 0, K::kTime, "total_ms", 1, {}},                   // scene not in this run
  };
  json r = run_bench(o);
  ASSERT_TRUE(r.contains("targets"));
  const json& t = r["targets"];
  ASSERT_EQ(t.size(), 4u);
  EXPECT_EQ(t[0]["result"], "PASS");
  EXPECT_EQ(t[1]["result"], "MISS");
  EXPECT_EQ(t[2]["result"], "PASS");
  EXPECT_EQ(t[3]["result"], "FAILED");
  EXPECT_NE(t[3]["error"].get<std::string>().find("no nope"), std::string::npos) << t[3].dump();
  // The ratio: medians of the method's and the reference's runs, three each.
  ASSERT_EQ(t[0]["run_method_ms"].size(), 3u);
  ASSERT_EQ(t[0]["run_reference_ms"].size(), 3u);
  EXPECT_NEAR(t[0]["value"].get<double>(), t[0]["reference_ms"].get<double>() / t[0]["method_ms"].get<double>(), 1e-9);
  EXPECT_EQ(t[0]["group"], "contact 16² 4 spp");
  EXPECT_EQ(t[2]["resolution"], 20);
  EXPECT_EQ(t[2]["run_values"].size(), 3u);
  // Two groups (16^2 with the reference, 20^2 without).
  ASSERT_EQ(r["scenes"].size(), 2u);
  EXPECT_EQ(r["scenes"][0]["methods"].size(), 3u);  // reference, hard, single-sample
  EXPECT_EQ(r["scenes"][1]["methods"].size(), 1u);
  EXPECT_EQ(r["scenes"][1]["resolution"], json({20, 20}));
  std::string md = bench_markdown(r);
  EXPECT_NE(md.find("| hard, 4 spp, contact 16²: speed-up over reference ≥ "), std::string::npos) << md;
  EXPECT_NE(md.find("**MISS**"), std::string::npos);
  EXPECT_NE(md.find("2 of 4 targets met"), std::string::npos) << md;

  // --methods keeps those methods' targets only.
  o.methods = {"single-sample"};
  json only = run_bench(o);
  ASSERT_EQ(only["targets"].size(), 1u);
  EXPECT_EQ(only["targets"][0]["method"], "single-sample");
  o.methods = {"afsm"};
  EXPECT_THROW(run_bench(o), Error);  // no target left
}

TEST(Bench, RatiosToTheReferenceMeasuredInTheSameRun) {
  BenchOptions o;
  o.suite = tiny_suite();
  o.methods = {"hard", "single-sample"};  // reference is added
  json r = run_bench(o);
  EXPECT_EQ(r["methods"], json({"reference", "hard", "single-sample"}));
  ASSERT_EQ(r["scenes"].size(), 1u);
  const json& scene = r["scenes"][0];
  EXPECT_EQ(scene["name"], "contact");
  EXPECT_EQ(scene["resolution"], json({24, 24}));
  double ref_ms = scene["reference_shadow_ms"].get<double>();
  EXPECT_GT(ref_ms, 0);
  ASSERT_EQ(scene["methods"].size(), 3u);
  for (const json& m : scene["methods"]) {
    ASSERT_TRUE(m["ok"].get<bool>()) << m.dump();
    EXPECT_EQ(m["run_shadow_ms"].size(), 3u);
    std::vector<double> t = m["run_shadow_ms"].get<std::vector<double>>();
    std::sort(t.begin(), t.end());
    EXPECT_EQ(m["shadow_ms"].get<double>(), t[1]);  // the median
    EXPECT_NEAR(m["speedup"].get<double>(), ref_ms / t[1], 1e-9);
  }
  EXPECT_DOUBLE_EQ(scene["methods"][0]["speedup"].get<double>(), 1.0);
  // What loading the scene cost, beside the methods' times.
  EXPECT_GT(scene["load_ms"].get<double>(), 0);
  EXPECT_GT(scene["peak_rss_bytes"].get<uint64_t>(), 0u);
  EXPECT_EQ(scene["embree"]["triangles"], scene["triangles"]);
  EXPECT_GT(scene["embree"]["bytes"].get<uint64_t>(), 0u);

  std::string md = bench_markdown(r);
  EXPECT_NE(md.find("- contact: 2,222 triangles; scene load "), std::string::npos) << md;
  EXPECT_NE(md.find("; peak resident memory "), std::string::npos) << md;
  EXPECT_NE(md.find("| method | contact |"), std::string::npos) << md;
  EXPECT_NE(md.find("| `reference` | "), std::string::npos) << md;
  EXPECT_NE(md.find("(1.00×)"), std::string::npos) << md;
  EXPECT_NE(md.find("| `single-sample` | "), std::string::npos) << md;
}

// The walk suite (issue 18 part 6): every frame of the animated scenes timed once per
// method, the methods interleaved frame by frame; the per-frame cost excludes the first frame
// (the light-space structures), the ratio is to reference's per-frame cost, and lam's target
// on the camera walk is graded (a structure test, not a timing one).
TEST(Bench, WalkSuiteTimesEveryFrameWithReuse) {
  BenchSuite s = bench_suite("walk", std::string(PENUMBRA_SOURCE_DIR) + "/scenes");
  ASSERT_EQ(s.scenes.size(), 3u);
  EXPECT_EQ(s.sequence_frames, 8);
  ASSERT_EQ(s.sequence_targets.size(), 1u);
  EXPECT_EQ(s.sequence_targets[0].method, "lam:unresolved=umbra");
  EXPECT_EQ(s.sequence_targets[0].goal, 50);
  s.scenes.resize(1);  // the camera walk around the bunny
  s.resolution = 24;
  s.light_samples = 4;
  s.sequence_frames = 3;
  BenchOptions o;
  o.suite = s;
  o.methods = {"lam", "hard"};
  const json r = run_bench(o);
  ASSERT_EQ(r.at("scenes").size(), 1u);
  const json& scene = r["scenes"][0];
  EXPECT_EQ(scene.value("name", ""), "bunny-walk");
  EXPECT_EQ(scene.value("frames", 0), 3);
  // reference first, then --methods, then the target's variant of lam (the paper's display).
  ASSERT_EQ(scene.at("methods").size(), 4u);
  EXPECT_EQ(scene["methods"][0].value("method", ""), "reference");
  EXPECT_EQ(scene["methods"][3].value("method", ""), "lam:unresolved=umbra");
  for (const json& m : scene["methods"]) {
    SCOPED_TRACE(m.value("method", ""));
    ASSERT_TRUE(m.value("ok", false)) << m.dump();
    ASSERT_EQ(m.at("run_shadow_ms").size(), 3u);
    // The camera walks around a still bunny: no object moves.
    EXPECT_EQ(m.value("moved_frames", -1), 0);
    EXPECT_EQ(m.value("refit_frames", -1), 0);
    // The per-frame cost is the median of frames 1 and 2.
    const double a = m["run_shadow_ms"][1].get<double>(), b = m["run_shadow_ms"][2].get<double>();
    EXPECT_EQ(m.value("shadow_ms", -1.0), std::min(a, b));
    EXPECT_EQ(m.value("first_frame_shadow_ms", -1.0), m["run_shadow_ms"][0].get<double>());
    EXPECT_NEAR(m.value("speedup", 0.0), scene.value("reference_shadow_ms", 0.0) / m.value("shadow_ms", 1.0), 1e-9);
  }
  ASSERT_TRUE(r.contains("targets"));
  EXPECT_EQ(r["targets"].size(), 1u);
  const std::string result = r["targets"][0].value("result", "");
  EXPECT_TRUE(result == "PASS" || result == "MISS");
  const std::string md = bench_markdown(r);
  EXPECT_NE(md.find("per frame"), std::string::npos);
  EXPECT_NE(md.find("`lam`"), std::string::npos);
}

TEST(Bench, AFailingMethodOrSceneIsReported) {
  testing::TempDir dir;
  std::ofstream(dir / "broken.json") << R"({"camera": {"eye": [0, 1, 2], "target": [0, 0, 0]},
    "lights": [{"type": "rect", "center": [0, 2, 0], "normal": [0, -1, 0], "size": [1, 1]}],
    "objects": [{"mesh": "missing.obj"}]})";
  BenchOptions o;
  o.suite = tiny_suite();
  o.suite.runs = 1;
  o.suite.warmup_runs = 0;
  o.suite.scenes.push_back(dir / "broken.json");
  o.methods = {"hard"};
  o.params = {"hard.nope=1"};
  json r = run_bench(o);
  ASSERT_EQ(r["scenes"].size(), 2u);
  const json& contact = r["scenes"][0];
  EXPECT_TRUE(contact["methods"][0]["ok"].get<bool>());   // reference
  EXPECT_FALSE(contact["methods"][1]["ok"].get<bool>());  // hard, with its message
  EXPECT_NE(contact["methods"][1]["error"].get<std::string>().find("nope"), std::string::npos);
  EXPECT_NE(r["scenes"][1]["error"].get<std::string>().find("missing.obj"), std::string::npos);
  std::string md = bench_markdown(r);
  EXPECT_NE(md.find("failed"), std::string::npos);
  EXPECT_NE(md.find("missing.obj"), std::string::npos);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
