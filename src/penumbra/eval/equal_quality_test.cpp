#include "penumbra/eval/equal_quality.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "penumbra/eval/comparison.h"
#include "penumbra/testing/compare_fixture.h"
#include "penumbra/testing/xml_check.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using nlohmann::json;
using testing::TempDir;
using testing::slurp;
using testing::tiny_contact_setup;

// A ladder with the closed forms of Monte Carlo: error = 0.2 / sqrt(N), time = 0.5 + 2 N ms.
std::vector<LadderPoint> closed_form_ladder(int max_samples) {
  std::vector<LadderPoint> l;
  for (int n = 1; n <= max_samples; n *= 2) l.push_back({double(n), 0.2 / std::sqrt(double(n)), 0.5 + 2.0 * n});
  return l;
}

TEST(EqualQuality, InterpolateLogLogIsExactOnPowerLaws) {
  // y = 3 x^-0.5 is a straight line in log-log: any two points give it back everywhere.
  auto f = [](double x) { return 3 / std::sqrt(x); };
  for (double x : {1.0, 1.5, 2.0, 3.7, 4.0, 9.0})  // between, at and beyond the ends
    EXPECT_NEAR(interpolate_log_log(1, f(1), 4, f(4), x), f(x), 1e-12) << x;
  // y = 5 x^2, the points in either order.
  EXPECT_NEAR(interpolate_log_log(8, 320, 2, 20, 4), 80, 1e-9);
  // A constant stays constant.
  EXPECT_NEAR(interpolate_log_log(1, 7, 16, 7, 3), 7, 1e-12);
}

TEST(EqualQuality, SearchFindsTheSampleCountOfAPowerLaw) {
  const std::vector<LadderPoint> ladder = closed_form_ladder(64);
  // Between rungs 8 and 16: error 0.2/sqrt(10) is at exactly 10 samples (a power law is a
  // straight line in log-log); the time between 16.5 and 32.5 ms, log-log as well.
  EqualQuality q = equal_quality_search(ladder, 0.2 / std::sqrt(10.0), 4.0);
  EXPECT_EQ(q.bound, QualityBound::kExact);
  EXPECT_NEAR(q.samples, 10, 1e-9);
  const double f = std::log(10.0 / 8) / std::log(2.0);
  const double ms = 16.5 * std::pow(32.5 / 16.5, f);
  EXPECT_NEAR(q.reference_ms, ms, 1e-9);
  EXPECT_NEAR(q.speedup, ms / 4.0, 1e-9);
  // On a rung: that rung exactly.
  q = equal_quality_search(ladder, 0.2 / std::sqrt(32.0), 1.0);
  EXPECT_NEAR(q.samples, 32, 1e-9);
  EXPECT_NEAR(q.reference_ms, 64.5, 1e-9);
  // Equal to the first rung: 1 sample, exactly.
  q = equal_quality_search(ladder, 0.2, 1.0);
  EXPECT_EQ(q.bound, QualityBound::kExact);
  EXPECT_EQ(q.samples, 1);
}

TEST(EqualQuality, BetterThanEveryRungIsALowerBoundNotAnExtrapolation) {
  const std::vector<LadderPoint> ladder = closed_form_ladder(64);
  EqualQuality q = equal_quality_search(ladder, 0.001, 10.0);  // 64 samples give 0.025
  EXPECT_EQ(q.bound, QualityBound::kAtLeast);
  EXPECT_EQ(q.samples, 64);           // ">= 64", not the 40,000 a power law would say
  EXPECT_EQ(q.reference_ms, 128.5);   // the last rung's time
  EXPECT_NEAR(q.speedup, 12.85, 1e-12);
  EXPECT_STREQ(bound_name(q.bound), "at_least");
  // Worse than one sample of the reference: "<= 1".
  q = equal_quality_search(ladder, 0.5, 0.1);
  EXPECT_EQ(q.bound, QualityBound::kAtMost);
  EXPECT_EQ(q.samples, 1);
  EXPECT_NEAR(q.speedup, 25, 1e-12);
  EXPECT_STREQ(bound_name(q.bound), "at_most");
  // No number without an error or a ladder.
  EXPECT_EQ(equal_quality_search(ladder, std::nan(""), 1).bound, QualityBound::kNone);
  EXPECT_TRUE(std::isnan(equal_quality_search({}, 0.1, 1).samples));
  // No time: samples but no speed-up.
  EXPECT_TRUE(std::isnan(equal_quality_search(ladder, 0.05, 0).speedup));
}

TEST(EqualQuality, NoisyLadderUsesTheFirstCrossingAndZeroErrorsLinearly) {
  // Noise can make a rung worse than the one before: the first rung at or below the method's
  // error and its predecessor bracket it.
  std::vector<LadderPoint> ladder = {{1, 0.1, 1}, {2, 0.05, 2}, {4, 0.06, 4}, {8, 0.02, 8}};
  EqualQuality q = equal_quality_search(ladder, 0.055, 1);
  EXPECT_GT(q.samples, 1);
  EXPECT_LT(q.samples, 2);
  // A rung with no error at all has no logarithm: linear in the error.
  ladder = {{1, 0.1, 1}, {2, 0.0, 3}};
  q = equal_quality_search(ladder, 0.05, 1);
  EXPECT_EQ(q.bound, QualityBound::kExact);
  EXPECT_NEAR(q.samples, 1.5, 1e-12);
  EXPECT_NEAR(q.reference_ms, 2, 1e-12);
}

// The known answer: the reference at 64 light samples, compared like any method, needs about
// 64 samples of the reference at equal quality (its ladder has a seed of its own, so not
// exactly 64: within a factor 1.5 by mean |dV| and by FLIP).
TEST(EqualQuality, TheReferenceAt64SamplesFindsAbout64) {
  TempDir dir;
  RunSetup setup = tiny_contact_setup();
  setup.apply("resolution", "40");
  setup.light_samples = 64;
  setup.reference_samples = 1024;
  CompareOptions o;
  o.methods = {"reference", "hard"};
  o.cache_dir = dir / "cache";
  Comparison c = run_comparison(setup, o);
  ASSERT_TRUE(c.has_ladder);
  EXPECT_EQ(c.ladder.max_samples, 1024);
  EXPECT_EQ(c.ladder.seed, ladder_seed(setup.seed));
  EXPECT_NE(c.ladder.seed, ground_truth_seed(setup.seed));
  // 1, 2, 4, ...: rendered until a rung is as good as the best method (the reference).
  ASSERT_GE(c.ladder.rungs.size(), 7u);
  for (size_t i = 0; i < c.ladder.rungs.size(); ++i) EXPECT_EQ(c.ladder.rungs[i].light_samples, 1 << i);
  const LadderRung& last = c.ladder.rungs.back();
  const MethodRun& ref = c.runs[0];
  EXPECT_TRUE(last.v_mae <= ref.v.mae && last.flip <= ref.flip);
  EXPECT_EQ(ref.eq_v.bound, QualityBound::kExact);
  EXPECT_GT(ref.eq_v.samples, 64 / 1.5);
  EXPECT_LT(ref.eq_v.samples, 64 * 1.5);
  EXPECT_GT(ref.eq_flip.samples, 64 / 1.5);
  EXPECT_LT(ref.eq_flip.samples, 64 * 1.5);
  // Hard shadows miss every penumbra: a few samples of the reference are as good.
  const MethodRun& hard = c.runs[1];
  EXPECT_LT(hard.eq_v.samples, 16);
  EXPECT_TRUE(std::isfinite(hard.eq_v.speedup));

  // Again: every rung from the cache, the same numbers.
  Comparison again = run_comparison(setup, o);
  ASSERT_EQ(again.ladder.rungs.size(), c.ladder.rungs.size());
  for (size_t i = 0; i < c.ladder.rungs.size(); ++i) {
    EXPECT_TRUE(again.ladder.rungs[i].from_cache);
    EXPECT_EQ(again.ladder.rungs[i].v_mae, c.ladder.rungs[i].v_mae);
    EXPECT_EQ(again.ladder.rungs[i].shadow_ms, c.ladder.rungs[i].shadow_ms);
  }
  EXPECT_EQ(again.runs[0].eq_v.bound, QualityBound::kExact);
}

TEST(EqualQuality, RungKeysDifferBySamplesAndWithTheGroundTruth) {
  RunSetup setup = tiny_contact_setup();
  EXPECT_NE(ladder_rung_key(setup, 4), ladder_rung_key(setup, 8));
  EXPECT_EQ(ladder_rung_key(setup, 4), ladder_rung_key(setup, 4));
  RunSetup more = setup;
  more.light_samples = 64;  // the methods' samples do not change the ladder
  EXPECT_EQ(ladder_rung_key(more, 4), ladder_rung_key(setup, 4));
  for (auto [key, value] : std::vector<std::pair<std::string, std::string>>{
           {"reference_spp", "32"}, {"light.size_scale", "2"}, {"resolution", "16"}, {"seed", "3"},
           {"reference.sampling", "area"}}) {
    RunSetup changed = setup;
    changed.apply(key, value);
    EXPECT_NE(ladder_rung_key(changed, 4), ladder_rung_key(setup, 4)) << key;
  }
}

TEST(EqualQuality, AMethodBetterThanEveryRungReadsAsALowerBound) {
  // A 4-sample ground truth: the reference at 64 samples is closer to it than any rung (at
  // most 4 samples, and noisy on both sides), so its equal-quality point is ">= 4".
  TempDir dir;
  RunSetup setup = tiny_contact_setup();
  setup.light_samples = 64;
  setup.reference_samples = 4;
  CompareOptions o;
  o.methods = {"reference"};
  o.cache_dir = dir / "cache";
  Comparison c = run_comparison(setup, o);
  ASSERT_EQ(c.ladder.rungs.size(), 3u);  // 1, 2, 4: never more than the ground truth's samples
  const MethodRun& r = c.runs[0];
  EXPECT_EQ(r.eq_v.bound, QualityBound::kAtLeast);
  EXPECT_EQ(r.eq_v.samples, 4);
  EXPECT_EQ(r.eq_v.reference_ms, c.ladder.rungs.back().shadow_ms);
  write_comparison(c, dir / "out", ReportOptions{0, false});
  json j = json::parse(slurp(dir / "out" / "results.json"));
  EXPECT_EQ(j["methods"][0]["eq_v_bound"], "at_least");
  EXPECT_EQ(j["methods"][0]["eq_v_spp"], 4);
  std::string html = slurp(dir / "out" / "index.html");
  EXPECT_NE(html.find(">≥ 4</td>"), std::string::npos);
  std::string csv = slurp(dir / "out" / "results.csv");
  EXPECT_NE(csv.find(",4,at_least,"), std::string::npos) << csv;
}

TEST(EqualQuality, JsonCsvPageAndChartCarryIt) {
  TempDir dir;
  CompareOptions o;
  o.methods = {"reference", "hard", "single-sample"};
  o.cache_dir = dir / "cache";
  RunSetup setup = tiny_contact_setup();
  setup.apply("hard.bogus", "1");  // a failed row as well (its message has no comma)
  Comparison c = run_comparison(setup, o);
  write_comparison(c, dir / "out", ReportOptions{0, false});

  json j = json::parse(slurp(dir / "out" / "results.json"));
  ASSERT_TRUE(j["reference_ladder"].is_object());
  EXPECT_EQ(j["reference_ladder"]["max_spp"], 16);
  EXPECT_EQ(j["reference_ladder"]["rungs"].size(), c.ladder.rungs.size());
  EXPECT_EQ(j["reference_ladder"]["rungs"][0]["spp"], 1);
  for (const char* k : {"v_mae", "flip", "shadow_ms", "cached", "cache_key"})
    EXPECT_TRUE(j["reference_ladder"]["rungs"][0].contains(k)) << k;
  for (const json& m : j["methods"]) {
    if (!m["ok"].get<bool>()) continue;
    for (const char* k : {"eq_v_spp", "eq_v_bound", "eq_v_reference_ms", "eq_v_speedup", "eq_flip_spp", "eq_flip_bound",
                          "eq_flip_reference_ms", "eq_flip_speedup"})
      ASSERT_TRUE(m.contains(k)) << m["method"] << " " << k;
    EXPECT_TRUE(m["eq_v_spp"].is_number()) << m.dump();
    EXPECT_TRUE(m["eq_v_bound"].is_string());
  }

  // CSV: the columns, and every row as long as the header.
  std::string csv = slurp(dir / "out" / "results.csv");
  std::istringstream lines(csv);
  std::string header, line;
  std::getline(lines, header);
  EXPECT_NE(header.find(",eq_v_spp,eq_v_bound,eq_v_reference_ms,eq_v_speedup,eq_flip_spp,eq_flip_bound,"
                        "eq_flip_reference_ms,eq_flip_speedup"),
            std::string::npos)
      << header;
  const size_t fields = std::count(header.begin(), header.end(), ',');
  int rows = 0;
  while (std::getline(lines, line)) {
    EXPECT_EQ(static_cast<size_t>(std::count(line.begin(), line.end(), ',')), fields) << line;
    ++rows;
  }
  EXPECT_EQ(rows, 3);

  // The page: the columns, the ladder and the charts inline; the charts as files too.
  std::string html = slurp(dir / "out" / "index.html");
  for (const char* s : {"data-key=\"eq_v_spp\"", "data-key=\"eq_v_speedup\"", "data-key=\"eq_flip_spp\"",
                        "data-key=\"eq_flip_speedup\"", "<table id=\"ladder\">", "mean |ΔV| against time"})
    EXPECT_NE(html.find(s), std::string::npos) << s;
  EXPECT_EQ(html.find("<?xml"), std::string::npos);
  for (const char* f : {"error-time.svg", "flip-time.svg"}) {
    std::string svg = slurp(dir / "out" / f), problem;
    EXPECT_TRUE(testing::xml_well_formed(svg, &problem)) << f << ": " << problem;
    // The ladder a curve labelled with its samples, then one point per method that ran.
    EXPECT_NE(svg.find("data-name=\"reference, 1–"), std::string::npos) << f;
    EXPECT_NE(svg.find(">1</text>"), std::string::npos) << f;
    EXPECT_NE(svg.find(">2</text>"), std::string::npos) << f;
    EXPECT_NE(svg.find("data-name=\"single-sample\""), std::string::npos) << f;
    EXPECT_EQ(svg.find("data-name=\"hard\""), std::string::npos) << f;  // it failed
  }

  // Without a ladder (switched off): no columns, null fields.
  o.equal_quality = false;
  Comparison plain = run_comparison(setup, o);
  EXPECT_FALSE(plain.has_ladder);
  json pj = comparison_json(plain);
  EXPECT_TRUE(pj["reference_ladder"].is_null());
  EXPECT_TRUE(pj["methods"][0]["eq_v_spp"].is_null());
  EXPECT_EQ(comparison_html(plain).find("data-key=\"eq_v_spp\""), std::string::npos);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
