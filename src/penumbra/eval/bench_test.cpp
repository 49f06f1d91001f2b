#include "penumbra/eval/bench.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "penumbra/core/error.h"
#include "penumbra/testing/compare_fixture.h"

namespace penumbra {
namespace {

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

  std::string md = bench_markdown(r);
  EXPECT_NE(md.find("| method | contact |"), std::string::npos) << md;
  EXPECT_NE(md.find("| `reference` | "), std::string::npos) << md;
  EXPECT_NE(md.find("(1.00×)"), std::string::npos) << md;
  EXPECT_NE(md.find("| `single-sample` | "), std::string::npos) << md;
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

}  // namespace
}  // namespace penumbra
