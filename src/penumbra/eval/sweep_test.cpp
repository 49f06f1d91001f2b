#include "penumbra/eval/sweep.h"

#include <gtest/gtest.h>

#include <cmath>

#include "penumbra/testing/compare_fixture.h"
#include "penumbra/testing/xml_check.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using nlohmann::json;
using testing::slurp;
using testing::TempDir;

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

TEST(Sweep, WritesACsvRowPerValueAndMethodAndPlotsThatParse) {
  TempDir dir;
  SweepOptions o;
  o.key = "light.size_scale";
  o.values = {"0.5", "1", "2"};
  o.methods = {"reference", "hard"};
  o.cache_dir = dir / "cache";
  Sweep s = run_sweep(testing::tiny_contact_setup(), o);
  ASSERT_EQ(s.rows.size(), 6u);
  EXPECT_TRUE(s.numeric);
  for (const SweepRow& r : s.rows) {
    EXPECT_TRUE(r.run.ok) << r.run.error;
    EXPECT_TRUE(r.run.color.empty());  // images are not kept
    EXPECT_TRUE(std::isfinite(r.run.v.mae));
  }
  // A bigger light: wider penumbrae that hard shadows miss.
  auto hard_mae = [&](const std::string& v) {
    for (const auto& r : s.rows)
      if (r.value == v && r.run.method == "hard") return r.run.v.mae;
    return std::numeric_limits<double>::quiet_NaN();
  };
  EXPECT_LT(hard_mae("0.5"), hard_mae("2"));
  // Each light size is a ground truth of its own (three cache entries of two files).
  size_t entries = 0;
  for (const auto& f : std::filesystem::directory_iterator(o.cache_dir)) entries += f.path().extension() == ".exr";
  EXPECT_EQ(entries, 3u);

  std::vector<std::filesystem::path> plots = write_sweep(s, dir / "out", {.extra_plots = {"flip"}});
  std::vector<std::string> csv = lines_of(slurp(dir / "out" / "sweep.csv"));
  ASSERT_EQ(csv.size(), 1u + 6u);
  EXPECT_EQ(csv[0].rfind("key,value,x,method,ok,error,light_samples,v_mae", 0), 0u) << csv[0];
  EXPECT_EQ(csv[1].rfind("light.size_scale,0.5,0.5,reference,true,,4,", 0), 0u) << csv[1];
  EXPECT_EQ(csv[6].rfind("light.size_scale,2,2,hard,true,,0,", 0), 0u) << csv[6];
  json j = json::parse(slurp(dir / "out" / "sweep.json"));
  EXPECT_EQ(j["rows"].size(), 6u);
  EXPECT_EQ(j["comparisons"].size(), 3u);
  EXPECT_EQ(j["rows"][5]["v_mae"].get<double>(), s.rows[5].run.v.mae);

  std::vector<std::string> names;
  for (const auto& p : plots) names.push_back(p.filename().string());
  EXPECT_EQ(names, (std::vector<std::string>{"error.svg", "time.svg", "rays.svg", "flip.svg"}));
  for (const auto& p : plots) {
    std::string svg = slurp(p), problem;
    EXPECT_TRUE(testing::xml_well_formed(svg, &problem)) << p << ": " << problem;
    EXPECT_NE(svg.find("data-name=\"reference\""), std::string::npos);
    EXPECT_NE(svg.find("data-name=\"hard\""), std::string::npos);
    EXPECT_NE(svg.find("<polyline"), std::string::npos);
  }
}

TEST(Sweep, TimingsOnlyCategoricalValuesAndMethodParameters) {
  TempDir dir;
  SweepOptions o;
  o.key = "single-sample.combine";
  o.values = {"min", "multiply", "add"};
  o.methods = {"single-sample"};
  o.ground_truth = false;
  Sweep s = run_sweep(testing::tiny_contact_setup(), o);
  EXPECT_FALSE(s.numeric);
  ASSERT_EQ(s.rows.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_TRUE(s.rows[i].run.ok) << s.rows[i].run.error;
    EXPECT_EQ(s.rows[i].x, static_cast<double>(i));
    EXPECT_EQ(s.rows[i].run.params["combine"], o.values[i]);
    EXPECT_TRUE(std::isnan(s.rows[i].run.v.mae));
  }
  auto plots = write_sweep(s, dir / "out");
  // time and rays (then single-sample's own extra numbers); no error without a ground truth.
  ASSERT_GE(plots.size(), 2u);
  EXPECT_EQ(plots[0].filename(), "time.svg");
  EXPECT_EQ(plots[1].filename(), "rays.svg");
  for (const auto& p : plots) EXPECT_NE(p.filename(), "error.svg");
  std::string svg = slurp(plots[0]), problem;
  EXPECT_TRUE(testing::xml_well_formed(svg, &problem)) << problem;
  EXPECT_NE(svg.find(">multiply<"), std::string::npos);
}

TEST(Sweep, BadValuesAndColumnsFailBeforeAnyRender) {
  SweepOptions o;
  o.key = "spp";
  o.values = {"4", "many"};
  o.methods = {"hard"};
  o.ground_truth = false;
  try {
    run_sweep(testing::tiny_contact_setup(), o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "sweep: spp=many: expected an integer in [1, 1048576]");
  }
  EXPECT_THROW(check_sweep_column("v_mea"), Error);
  EXPECT_NO_THROW(check_sweep_column("extra.ldi_layers"));
  EXPECT_NO_THROW(check_sweep_column("phase_trace_ms"));
  EXPECT_NO_THROW(check_sweep_column("rays_traced"));
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

TEST(Sweep, NumbersAMethodReportsInExtraArePlottedUnasked) {
  testing::TempDir dir;
  Sweep s;
  s.scene = "scenes/plant.json";
  s.key = "spp";
  s.values = {"4", "16"};
  s.methods = {"lam"};
  for (int i = 0; i < 2; ++i) {
    SweepRow row;
    row.value = s.values[i];
    row.x = i == 0 ? 4 : 16;
    row.run.method = "lam";
    row.run.ok = true;
    row.run.times.shadow_ms = 1 + i;
    row.run.stats.extra = {{"ldi_depth_complexity", 1.5 + i},
                           {"note", "text is not plotted"},
                           {"ldi", {{"layers", 100 * (i + 1)}, {"flag", true}}},
                           {"curve", json::array({{{"samples", 1}, {"dc", 1.0}}, {{"samples", 4}, {"dc", 1.25 + i}}})}};
    s.rows.push_back(row);
  }
  auto plots = write_sweep(s, dir.path());
  std::vector<std::string> names;
  for (const auto& p : plots) names.push_back(p.filename().string());
  EXPECT_EQ(names, (std::vector<std::string>{"time.svg", "extra.ldi_depth_complexity.svg"}));
  std::string csv = testing::slurp(dir / "sweep.csv");
  EXPECT_NE(csv.find(",extra.ldi_depth_complexity"), std::string::npos) << csv;
  EXPECT_EQ(csv.find("note"), std::string::npos) << csv;
  EXPECT_EQ(csv.find("flag"), std::string::npos) << csv;
  // Nested numbers are columns (an array: its last element), plotted when asked for.
  EXPECT_NE(csv.find(",extra.ldi.layers"), std::string::npos) << csv;
  EXPECT_EQ(sweep_value(s.rows[1], "extra.curve.dc"), 2.25);
  EXPECT_EQ(sweep_value(s.rows[1], "extra.curve.samples"), 4);
  EXPECT_EQ(sweep_value(s.rows[0], "extra.ldi.layers"), 100);
  EXPECT_TRUE(std::isnan(sweep_value(s.rows[0], "extra.ldi.flag")));
  auto more = write_sweep(s, dir / "more", {.extra_plots = {"extra.curve.dc"}});
  EXPECT_EQ(more.back().filename(), "extra.ldi_depth_complexity.svg");
  EXPECT_EQ(more[1].filename(), "extra.curve.dc.svg");
  std::string problem;
  EXPECT_TRUE(testing::xml_well_formed(testing::slurp(plots[1]), &problem)) << problem;
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
