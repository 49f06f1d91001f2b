#include "penumbra/eval/comparison.h"

#include <gtest/gtest.h>

#include <fstream>

#include <cmath>
#include <map>
#include <optional>
#include <regex>

#include "penumbra/core/file_util.h"
#include "penumbra/core/parallel.h"
#include "penumbra/eval/metrics.h"
#include "penumbra/render/renderer.h"
#include "penumbra/testing/compare_fixture.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using nlohmann::json;
using testing::TempDir;
using testing::slurp;
using testing::tiny_contact_setup;

const MethodRun& find_run(const Comparison& c, const std::string& name) {
  for (const auto& r : c.runs)
    if (r.method == name) return r;
  throw Error("no run of {}", name);
}

TEST(Comparison, RunsEveryMethodAgainstTheGroundTruth) {
  TempDir dir;
  CompareOptions o;
  o.methods = {"reference", "hard", "single-sample"};
  o.cache_dir = dir / "cache";
  RunSetup setup = tiny_contact_setup();
  Comparison c = run_comparison(setup, o);
  ASSERT_TRUE(c.has_ground_truth);
  EXPECT_EQ(c.width, 32);
  EXPECT_EQ(c.truth.light_samples, 16);
  EXPECT_EQ(c.truth.seed, ground_truth_seed(0));
  ASSERT_EQ(c.runs.size(), 3u);
  for (const MethodRun& r : c.runs) {
    ASSERT_TRUE(r.ok) << r.method << ": " << r.error;
    EXPECT_TRUE(std::isfinite(r.v.mae)) << r.method;
    EXPECT_GE(r.v.rmse, r.v.mae);
    EXPECT_GE(r.v.max_abs, r.v.rmse);
    EXPECT_TRUE(r.flip >= 0 && r.flip <= 1) << r.flip;
    EXPECT_GT(r.times.total_ms, 0);
    EXPECT_EQ(r.color.width(), 32);
    EXPECT_GT(r.stats.rays_traced, 0u) << r.method;
  }
  // The metrics are those of eval/ on the images the runs kept.
  const MethodRun& hard = find_run(c, "hard");
  ErrorStats direct = compare_images(hard.visibility, c.truth.visibility);
  EXPECT_EQ(hard.v.mae, direct.mae);
  EXPECT_EQ(hard.color_psnr, compare_images(display_srgb(hard.color), display_srgb(c.truth.color)).psnr);
  // The reference at 4 samples is noisy but unbiased; hard shadows miss every penumbra.
  const MethodRun& ref = find_run(c, "reference");
  EXPECT_LT(ref.v.mae, hard.v.mae);
  EXPECT_EQ(ref.light_samples, 4);
  EXPECT_EQ(hard.light_samples, 0);
  // At most one ray per light sample and view sample (none toward a light behind the point).
  EXPECT_GT(rays_per_view_sample(ref), 2.0);
  EXPECT_LE(rays_per_view_sample(ref), 4.0);
  EXPECT_LE(rays_per_view_sample(hard), 1.0);
  // Speed-ups are against the reference method of this run.
  EXPECT_EQ(c.speedup_basis, "reference");
  EXPECT_DOUBLE_EQ(ref.speedup, 1.0);
  EXPECT_NEAR(hard.speedup, ref.times.shadow_ms / hard.times.shadow_ms, 1e-9);
  // The ground truth's own seed: the reference row is not the ground truth at equal spp.
  EXPECT_GT(ref.v.mae, 0);
  // The wide-scene line (issue 34): the methods above hard's error, here exactly those whose
  // mean |dV| is larger, in run order; in results.json too.
  std::vector<std::string> expect_worse;
  for (const MethodRun& r : c.runs)
    if (r.v.mae > hard.v.mae) expect_worse.push_back(r.method);
  EXPECT_EQ(worse_than_hard(c), expect_worse);
  EXPECT_EQ(comparison_json(c).at("worse_than_hard").get<std::vector<std::string>>(), expect_worse);
  Comparison no_hard = c;
  no_hard.runs.erase(no_hard.runs.begin() + (&hard - c.runs.data()));
  EXPECT_TRUE(worse_than_hard(no_hard).empty());
  EXPECT_FALSE(comparison_json(no_hard).contains("worse_than_hard"));
}

// What penumbra.distributed does with jobs: the ground truth, each method against it, the
// ladder, then the speed-ups, gives run_comparison's numbers (times apart); and results.json
// reads back into the same Comparison.
TEST(Comparison, StepsGiveRunComparisonsNumbersAndResultsJsonReadsBack) {
  TempDir dir;
  CompareOptions o;
  o.methods = {"hard", "pcss", "pcss:blocker_samples=0", "reference"};
  o.cache_dir = dir / "cache";
  o.equal_quality = true;
  const RunSetup setup = tiny_contact_setup();
  const Comparison whole = run_comparison(setup, o);

  const Scene scene = setup.load();
  Comparison steps = comparison_header(setup, scene);
  steps.truth = ground_truth(setup, scene, o.cache_dir);
  steps.has_ground_truth = true;
  for (const std::string& label : o.methods)
    steps.runs.push_back(method_run_from_json(
        method_run_json(compare_method(setup, scene, label, &steps.truth, o))));  // as a job's entry travels
  std::optional<ReferenceLadder> ladder = comparison_ladder(steps, setup, scene, o);
  ASSERT_TRUE(ladder.has_value());
  apply_ladder(steps, reference_ladder_from_json(reference_ladder_json(*ladder)));
  apply_speedups(steps);

  ASSERT_EQ(steps.runs.size(), whole.runs.size());
  for (size_t i = 0; i < whole.runs.size(); ++i) {
    const MethodRun &a = whole.runs[i], &b = steps.runs[i];
    EXPECT_EQ(a.method, b.method);
    EXPECT_EQ(a.ok, b.ok) << a.method;
    EXPECT_EQ(a.error, b.error);
    if (!a.ok) continue;
    EXPECT_EQ(a.v.mae, b.v.mae) << a.method;
    EXPECT_EQ(a.flip, b.flip) << a.method;
    EXPECT_EQ(a.color_psnr, b.color_psnr) << a.method;
    EXPECT_EQ(a.stats.rays_traced, b.stats.rays_traced) << a.method;
    EXPECT_EQ(a.eq_v.bound, b.eq_v.bound) << a.method;
    EXPECT_EQ(a.eq_v.samples, b.eq_v.samples) << a.method;
    EXPECT_EQ(a.params, b.params);
  }
  EXPECT_FALSE(steps.runs[2].ok);
  EXPECT_NE(steps.runs[2].error.find("blocker_samples"), std::string::npos);
  EXPECT_EQ(steps.speedup_basis, "reference");

  // results.json -> Comparison -> results.json is the identity, phase order included.
  const json j = comparison_json(whole);
  const Comparison back = comparison_from_json(j);
  EXPECT_EQ(comparison_json(back), j);
  EXPECT_EQ(comparison_csv(back), comparison_csv(whole));
  EXPECT_EQ(back.runs[0].stats.phases_ms, whole.runs[0].stats.phases_ms);
  EXPECT_TRUE(std::isnan(back.runs[2].v.mae));
}

// compare --objects: each group's error is the metric over exactly its objects' pixels, the
// groups of disjoint objects add up to the group of all of them, and that group's error is the
// whole image's over the pixels that show a surface (the background's are 0 in every method).
TEST(Comparison, ErrorsByObjectAddUpToTheWholeImage) {
  TempDir dir;
  CompareOptions o;
  o.methods = {"reference", "hard"};
  o.cache_dir = dir / "cache";
  o.equal_quality = false;
  o.objects = {"ground", "b*", "*"};  // contact.json: ground, box, ball
  RunSetup setup = tiny_contact_setup();
  const Comparison c = run_comparison(setup, o);
  ASSERT_EQ(c.object_groups.size(), 3u);
  const ObjectGroup &ground = c.object_groups[0], &boxes = c.object_groups[1], &all = c.object_groups[2];
  EXPECT_EQ(ground.objects, 1u);
  EXPECT_EQ(boxes.objects, 2u);  // box and ball
  EXPECT_EQ(all.objects, 3u);
  EXPECT_GT(ground.pixels, 0u);
  EXPECT_GT(boxes.pixels, 0u);
  EXPECT_EQ(ground.pixels + boxes.pixels, all.pixels);
  // The masks are the camera pass's hits: every pixel off `all` is background (V = 1 everywhere).
  const MethodRun& hard = find_run(c, "hard");
  size_t background = 0;
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x)
      if (all.mask.at(x, y) == 0.0f) {
        ++background;
        EXPECT_EQ(c.truth.visibility.at(x, y), 1.0f);
        EXPECT_EQ(hard.visibility.at(x, y), 1.0f);
      }
  EXPECT_EQ(background + all.pixels, static_cast<size_t>(c.width) * c.height);
  EXPECT_GT(background, 0u);
  for (const MethodRun& r : c.runs) {
    ASSERT_EQ(r.v_objects.size(), 3u) << r.method;
    const ErrorStats &g = r.v_objects[0], &b = r.v_objects[1], &a = r.v_objects[2];
    EXPECT_EQ(g.pixels, ground.pixels);
    MetricOptions on_ground;
    on_ground.mask = &ground.mask;
    EXPECT_EQ(g.mae, compare_images(r.visibility, c.truth.visibility, on_ground).mae) << r.method;
    // Sums of |dV| and dV over disjoint groups add up; over every surface they are the image's.
    EXPECT_NEAR(g.mae * g.pixels + b.mae * b.pixels, a.mae * a.pixels, 1e-9) << r.method;
    EXPECT_NEAR(g.mean_signed * g.pixels + b.mean_signed * b.pixels, a.mean_signed * a.pixels, 1e-9);
    EXPECT_NEAR(a.mae * a.pixels, r.v.mae * c.width * c.height, 1e-9) << r.method;
    EXPECT_GT(a.mae, r.v.mae);  // the background's zeros are left out
  }
  // results.json carries them and reads back; the CSV has two columns a group.
  const Comparison back = comparison_from_json(comparison_json(c));
  ASSERT_EQ(back.object_groups.size(), 3u);
  EXPECT_EQ(back.object_groups[1].pattern, "b*");
  EXPECT_EQ(back.object_groups[1].pixels, boxes.pixels);
  EXPECT_EQ(find_run(back, "hard").v_objects[0].mae, hard.v_objects[0].mae);
  EXPECT_EQ(comparison_csv(back), comparison_csv(c));
  EXPECT_NE(comparison_csv(c).find(",v_mae[ground],v_mean_signed[ground],v_mae[b*]"), std::string::npos);
  const std::string page = comparison_html(c, {});
  EXPECT_NE(page.find("<table id=\"objects\">"), std::string::npos);
  EXPECT_NE(page.find("<code>b*</code>"), std::string::npos);
}

// A pattern that names no object fails before any render, naming the pattern and the objects.
TEST(Comparison, AnObjectPatternThatMatchesNothingNamesTheObjects) {
  TempDir dir;
  CompareOptions o;
  o.methods = {"hard"};
  o.cache_dir = dir / "cache";
  o.objects = {"ground", "leaves*"};
  RunSetup setup = tiny_contact_setup();
  try {
    run_comparison(setup, o);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "--objects: 'leaves*' matches no object of the scene (its objects: ground, box, ball)");
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "cache"));  // nothing rendered, not even the ground truth
  o.objects = {""};
  EXPECT_THROW(run_comparison(setup, o), Error);
}

TEST(Comparison, AFailingMethodIsReportedAndTheOthersStillRun) {
  TempDir dir;
  CompareOptions o;
  o.methods = {"hard", "single-sample", "reference"};
  o.cache_dir = dir / "cache";
  RunSetup setup = tiny_contact_setup();
  setup.apply("hard.no_such_param", "1");  // create_method throws for hard only
  Comparison c = run_comparison(setup, o);
  const MethodRun& hard = find_run(c, "hard");
  EXPECT_FALSE(hard.ok);
  EXPECT_NE(hard.error.find("no_such_param"), std::string::npos) << hard.error;
  EXPECT_TRUE(find_run(c, "single-sample").ok);
  EXPECT_TRUE(find_run(c, "reference").ok);

  write_comparison(c, dir / "out");
  std::string html = slurp(dir / "out" / "index.html");
  EXPECT_NE(html.find("<tr class=\"failed\" data-method=\"hard\">"), std::string::npos);
  EXPECT_NE(html.find("unknown parameter &#39;no_such_param&#39;"), std::string::npos);
  EXPECT_NE(html.find("<div class=\"card failed\" data-method=\"hard\">"), std::string::npos);
  json j = json::parse(slurp(dir / "out" / "results.json"));
  for (const json& m : j["methods"]) {
    if (m["method"] == "hard") {
      EXPECT_FALSE(m["ok"].get<bool>());
      EXPECT_EQ(m["error"], hard.error);
    } else {
      EXPECT_TRUE(m["ok"].get<bool>());
    }
  }
  std::string csv = slurp(dir / "out" / "results.csv");
  EXPECT_NE(csv.find("\nhard,false,"), std::string::npos);
  // Every CSV row has as many fields as the header (the error has no comma here).
  std::istringstream lines(csv);
  std::string header, line;
  std::getline(lines, header);
  size_t fields = std::count(header.begin(), header.end(), ',');
  while (std::getline(lines, line)) EXPECT_EQ(static_cast<size_t>(std::count(line.begin(), line.end(), ',')), fields) << line;
}

TEST(Comparison, VariantsOfOneMethodSideBySide) {
  CompareOptions o;
  o.methods = {"single-sample", "single-sample:combine=multiply", "single-sample:combine=bogus"};
  o.ground_truth = false;
  Comparison c = run_comparison(tiny_contact_setup(), o);
  ASSERT_EQ(c.runs.size(), 3u);
  EXPECT_TRUE(c.runs[0].ok);
  EXPECT_TRUE(c.runs[1].ok);
  EXPECT_EQ(c.runs[0].params["combine"], "min");
  EXPECT_EQ(c.runs[1].params["combine"], "multiply");
  EXPECT_EQ(c.runs[1].method, "single-sample:combine=multiply");
  EXPECT_FALSE(c.runs[2].ok);  // a bad value fails that variant only
  EXPECT_NE(c.runs[2].error.find("bogus"), std::string::npos) << c.runs[2].error;
}

TEST(Comparison, UnknownPlainParameterFailsBeforeRendering) {
  CompareOptions o;
  o.methods = {"hard"};
  RunSetup setup = tiny_contact_setup();
  setup.apply("sampling", "area");  // only reference declares it
  EXPECT_THROW(run_comparison(setup, o), Error);
}

TEST(Comparison, TheReferenceCacheIsHitTheSecondTime) {
  TempDir dir;
  CompareOptions o;
  o.methods = {"hard"};
  o.cache_dir = dir / "cache";
  RunSetup setup = tiny_contact_setup();
  EXPECT_FALSE(ground_truth_cached(setup, o.cache_dir));
  Comparison first = run_comparison(setup, o);
  EXPECT_FALSE(first.truth.from_cache);
  EXPECT_TRUE(ground_truth_cached(setup, o.cache_dir));
  Comparison second = run_comparison(setup, o);
  EXPECT_TRUE(second.truth.from_cache);
  EXPECT_EQ(first.truth.key, second.truth.key);
  EXPECT_EQ(first.truth.visibility.data(), second.truth.visibility.data());  // EXR float: exact
  EXPECT_EQ(first.truth.color.data(), second.truth.color.data());
  EXPECT_EQ(find_run(first, "hard").v.mae, find_run(second, "hard").v.mae);
  EXPECT_EQ(first.truth.total_ms, second.truth.total_ms);  // the time of the render that made it

  // The methods' spp does not change the ground truth; anything that changes its pixels does.
  RunSetup more = setup;
  more.light_samples = 64;
  EXPECT_EQ(ground_truth_key(more), first.truth.key);
  for (auto [key, value] : std::vector<std::pair<std::string, std::string>>{
           {"reference_spp", "32"}, {"light.size_scale", "2"}, {"resolution", "16"}, {"seed", "3"},
           {"reference.sampling", "area"}}) {
    RunSetup changed = setup;
    changed.apply(key, value);
    EXPECT_NE(ground_truth_key(changed), first.truth.key) << key;
  }
  // No cache folder: always rendered.
  o.cache_dir.clear();
  EXPECT_FALSE(run_comparison(setup, o).truth.from_cache);
}

TEST(Comparison, ADamagedCacheEntryIsRenderedAgain) {
  // A bit flipped inside the cached EXR (its pixels still decode) or a truncated file: the
  // checksum in the meta file no longer matches, so the entry is a miss, rendered again and
  // rewritten; the next run hits it.
  TempDir dir;
  CompareOptions o;
  o.methods = {"hard"};
  o.cache_dir = dir / "cache";
  RunSetup setup = tiny_contact_setup();
  const Comparison first = run_comparison(setup, o);
  ASSERT_FALSE(first.truth.from_cache);
  const std::filesystem::path exr = first.truth.cache_file;
  for (int damage = 0; damage < 2; ++damage) {
    std::string bytes = read_text_file(exr);
    if (damage == 0) bytes[bytes.size() - 40] ^= 0x10;  // inside the last scanlines' data
    else bytes.resize(bytes.size() / 2);
    {
      std::ofstream f(exr, std::ios::binary | std::ios::trunc);
      f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    }
    const Comparison again = run_comparison(setup, o);
    EXPECT_FALSE(again.truth.from_cache) << damage;
    EXPECT_EQ(again.truth.visibility.data(), first.truth.visibility.data()) << damage;
    EXPECT_TRUE(run_comparison(setup, o).truth.from_cache) << damage;
  }
}

TEST(Comparison, MedianOfSeveralRunsAndWarmups) {
  CompareOptions o;
  o.methods = {"hard"};
  o.ground_truth = false;
  o.runs = 3;
  o.warmup_runs = 1;
  Comparison c = run_comparison(tiny_contact_setup(), o);
  const MethodRun& r = c.runs[0];
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(r.run_shadow_ms.size(), 3u);
  std::vector<double> t = r.run_shadow_ms;
  std::sort(t.begin(), t.end());
  EXPECT_EQ(r.times.shadow_ms, t[1]);
  EXPECT_FALSE(r.color.empty());  // the images survive dropping the warm-up
  // No ground truth: no error metrics, no basis for a speed-up without the reference.
  EXPECT_FALSE(c.has_ground_truth);
  EXPECT_TRUE(std::isnan(r.v.mae));
  EXPECT_TRUE(std::isnan(r.speedup));
  EXPECT_EQ(comparison_progress_units(tiny_contact_setup(), o), 32u * 32u * 4u);
}

TEST(Comparison, InterleavedRunsKeepEveryMethodsMediansAndImages) {
  CompareOptions o;
  o.methods = {"reference", "hard", "hard:bogus=1"};
  o.ground_truth = false;
  o.runs = 3;
  o.warmup_runs = 1;
  o.interleave = true;
  Comparison c = run_comparison(tiny_contact_setup(), o);
  ASSERT_EQ(c.runs.size(), 3u);
  for (int k = 0; k < 2; ++k) {
    const MethodRun& r = c.runs[k];
    ASSERT_TRUE(r.ok) << r.error;
    ASSERT_EQ(r.run_shadow_ms.size(), 3u);
    ASSERT_EQ(r.run_total_ms.size(), 3u);
    ASSERT_EQ(r.run_phases_ms.size(), 3u);
    std::vector<double> t = r.run_shadow_ms;
    std::sort(t.begin(), t.end());
    EXPECT_EQ(r.times.shadow_ms, t[1]);
    EXPECT_FALSE(r.color.empty());
  }
  EXPECT_FALSE(c.runs[2].ok);  // a failing method fails alone
  EXPECT_NE(c.runs[2].error.find("bogus"), std::string::npos);
  EXPECT_NEAR(c.runs[1].speedup, c.runs[0].times.shadow_ms / c.runs[1].times.shadow_ms, 1e-9);
}

TEST(Comparison, SpeedupAgainstTheGroundTruthWithoutTheReferenceMethod) {
  TempDir dir;
  CompareOptions o;
  o.methods = {"hard"};
  o.cache_dir = dir / "cache";
  Comparison c = run_comparison(tiny_contact_setup(), o);
  EXPECT_EQ(c.speedup_basis, "ground truth");
  EXPECT_GT(c.speedup_basis_ms, 0);
  EXPECT_TRUE(std::isfinite(c.runs[0].speedup));
}

// Issue 32: a cached time is a speed-up's basis only where this machine measured it with this
// thread count. Entries whose times another machine measured (their records renamed here) are
// timed again, their images and errors still from the cache; the entry then keeps both
// records. And a time from elsewhere that reaches apply_speedups (a cluster's job that did not
// time it) gives no speed-ups.
TEST(Comparison, ACachedTimeFromAnotherMachineIsTimedAgain) {
  TempDir dir;
  CompareOptions o;
  o.methods = {"hard"};
  o.cache_dir = dir / "cache";
  const RunSetup setup = tiny_contact_setup();
  ThreadLimit limit(1);
  const Comparison first = run_comparison(setup, o);
  ASSERT_TRUE(first.has_ladder);
  EXPECT_EQ(first.truth.time_basis, TimeBasis::kMeasuredNow);
  const Comparison second = run_comparison(setup, o);
  EXPECT_EQ(second.truth.time_basis, TimeBasis::kCachedHere);
  EXPECT_EQ(second.truth.total_ms, first.truth.total_ms);
  EXPECT_EQ(second.speedup_time_basis, TimeBasis::kCachedHere);
  for (const LadderRung& r : second.ladder.rungs) {
    EXPECT_TRUE(r.from_cache);
    EXPECT_EQ(r.time_basis, TimeBasis::kCachedHere);
  }
  EXPECT_EQ(ladder_time_basis_text(second.ladder), "from the cache, same machine and threads");

  // Every record of the cache now says another machine measured it.
  for (const auto& e : std::filesystem::directory_iterator(o.cache_dir)) {
    if (e.path().extension() != ".json") continue;
    json entry = json::parse(slurp(e.path()));
    ASSERT_EQ(entry["timings"].size(), 1u) << e.path();
    entry["timings"][0]["machine"] = "elsewhere / another CPU / 64 logical cores";
    write_text_file_atomic(e.path(), entry.dump());
  }
  const Comparison third = run_comparison(setup, o);
  EXPECT_TRUE(third.truth.from_cache);
  EXPECT_EQ(third.truth.visibility.data(), first.truth.visibility.data());
  EXPECT_EQ(third.truth.time_basis, TimeBasis::kMeasuredNow);
  EXPECT_EQ(third.speedup_time_basis, TimeBasis::kMeasuredNow);
  EXPECT_TRUE(std::isfinite(third.runs[0].speedup));
  ASSERT_EQ(third.ladder.rungs.size(), second.ladder.rungs.size());
  for (size_t k = 0; k < third.ladder.rungs.size(); ++k) {
    EXPECT_TRUE(third.ladder.rungs[k].from_cache);
    EXPECT_EQ(third.ladder.rungs[k].time_basis, TimeBasis::kMeasuredNow);
    EXPECT_EQ(third.ladder.rungs[k].v_mae, second.ladder.rungs[k].v_mae);  // the cached errors
  }
  EXPECT_NE(speedup_basis_text(third).find("(time measured now)"), std::string::npos) << speedup_basis_text(third);
  for (const auto& e : std::filesystem::directory_iterator(o.cache_dir))
    if (e.path().extension() == ".json")
      EXPECT_EQ(json::parse(slurp(e.path()))["timings"].size(), 2u) << e.path();
  EXPECT_EQ(run_comparison(setup, o).truth.time_basis, TimeBasis::kCachedHere);

  Comparison elsewhere = second;
  elsewhere.truth.time_basis = TimeBasis::kCachedElsewhere;
  for (MethodRun& r : elsewhere.runs) r.speedup = std::nan("");
  apply_speedups(elsewhere);
  EXPECT_EQ(elsewhere.speedup_basis, "ground truth");
  EXPECT_TRUE(std::isnan(elsewhere.runs[0].speedup));
  EXPECT_NE(speedup_basis_text(elsewhere).find("another machine or thread count: no speed-ups"), std::string::npos);
  EXPECT_NE(comparison_html(elsewhere).find("so no speed-ups are given"), std::string::npos);
  // results.json carries the bases back.
  const Comparison back = comparison_from_json(comparison_json(third));
  EXPECT_EQ(back.truth.time_basis, TimeBasis::kMeasuredNow);
  EXPECT_EQ(back.ladder.rungs[0].time_basis, TimeBasis::kMeasuredNow);
  EXPECT_EQ(comparison_from_json(comparison_json(second)).speedup_time_basis, TimeBasis::kCachedHere);
}

// --- results.json against the page's table

std::string html_unescape(std::string s) {
  for (auto [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"&quot;", "\""}, {"&#39;", "'"}, {"&lt;", "<"}, {"&gt;", ">"}, {"&amp;", "&"}}) {
    for (size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size())) s.replace(p, from.size(), to);
  }
  return s;
}

struct Cell {
  std::string value;    // data-value (JSON text)
  std::string display;  // the text shown
};

// method -> key -> cell, from the <tbody> of the results table.
std::map<std::string, std::map<std::string, Cell>> parse_table(const std::string& html) {
  std::map<std::string, std::map<std::string, Cell>> out;
  size_t b = html.find("<table id=\"results\">");
  size_t body = html.find("<tbody>", b), end = html.find("</tbody>", b);
  EXPECT_NE(b, std::string::npos);
  std::string rows = html.substr(body, end - body);
  static const std::regex row_re("<tr data-method=\"([^\"]+)\">");
  static const std::regex cell_re("<td data-key=\"([a-z_]+)\" data-value=\"([^\"]*)\"(?: class=\"best\")?>([^<]*)</td>");
  for (size_t p = rows.find("<tr"); p != std::string::npos;) {
    size_t q = rows.find("</tr>", p);
    std::string row = rows.substr(p, q - p);
    std::smatch m;
    if (std::regex_search(row, m, row_re)) {
      std::string method = m[1];
      for (auto it = std::sregex_iterator(row.begin(), row.end(), cell_re); it != std::sregex_iterator(); ++it)
        out[method][(*it)[1]] = {html_unescape((*it)[2]), html_unescape((*it)[3])};
    }
    p = rows.find("<tr", q);
  }
  return out;
}

double parse_display(const std::string& key, std::string text) {
  auto strip = [&](const std::string& s) {
    for (size_t p = text.find(s); p != std::string::npos; p = text.find(s)) text.erase(p, s.size());
  };
  strip(",");
  strip("×");
  double scale = 1;
  if (key == "memory_bytes") {
    for (auto [unit, f] : std::vector<std::pair<std::string, double>>{
             {" KiB", 1024.0}, {" MiB", 1048576.0}, {" GiB", 1073741824.0}, {" B", 1.0}}) {
      if (text.size() > unit.size() && text.substr(text.size() - unit.size()) == unit) {
        text.erase(text.size() - unit.size());
        scale = f;
        break;
      }
    }
  }
  return std::stod(text) * scale;
}

TEST(Comparison, ResultsJsonMatchesTheHtmlTable) {
  TempDir dir;
  CompareOptions o;
  o.methods = {"reference", "hard", "single-sample"};
  o.cache_dir = dir / "cache";
  RunSetup setup = tiny_contact_setup();
  setup.apply("single-sample.bogus", "1");  // one failed row as well
  Comparison c = run_comparison(setup, o);
  write_comparison(c, dir / "out");
  json j = json::parse(slurp(dir / "out" / "results.json"));
  auto table = parse_table(slurp(dir / "out" / "index.html"));

  const std::vector<std::string> keys = {"light_samples", "v_mae", "v_rmse", "v_max", "v_mean_signed", "color_psnr",
                                         "flip", "shadow_ms", "speedup", "camera_pass_ms", "total_ms", "rays_traced",
                                         "memory_bytes"};
  int checked = 0;
  ASSERT_EQ(j["methods"].size(), 3u);
  for (const json& m : j["methods"]) {
    std::string name = m["method"];
    if (!m["ok"].get<bool>()) {
      EXPECT_EQ(table.count(name), 0u) << name << " failed: it has no numeric cells";
      continue;
    }
    ASSERT_EQ(table.count(name), 1u) << name;
    for (const std::string& key : keys) {
      ASSERT_EQ(table[name].count(key), 1u) << name << " " << key;
      const Cell& cell = table[name][key];
      // The exact value: the same JSON number.
      EXPECT_EQ(json::parse(cell.value), m[key]) << name << " " << key;
      // The text shown: that number rounded for reading.
      if (m[key].is_number()) {
        double v = m[key].get<double>();
        if (key == "light_samples" && v == 0) {
          EXPECT_EQ(cell.display, "—");
          continue;
        }
        double shown = parse_display(key, cell.display);
        double tol = key == "color_psnr" ? 0.0051 : std::abs(v) * 5.01e-3 + 1e-12;
        EXPECT_NEAR(shown, v, tol) << name << " " << key << ": '" << cell.display << "'";
        ++checked;
      }
    }
  }
  EXPECT_GE(checked, 2 * 12);
}

TEST(Comparison, PageIsSelfContained) {
  TempDir dir;
  CompareOptions o;
  o.methods = {"hard", "reference"};
  o.cache_dir = dir / "cache";
  Comparison c = run_comparison(tiny_contact_setup(), o);
  std::string html = comparison_html(c);
  // Nothing fetched: no URLs but data URIs.
  EXPECT_EQ(html.find("http://"), std::string::npos);
  EXPECT_EQ(html.find("https://"), std::string::npos);
  EXPECT_EQ(html.find("src=\"file"), std::string::npos);
  // Every image is an embedded PNG: the ground truth's two, three per method.
  size_t images = 0;
  for (size_t p = html.find("<img "); p != std::string::npos; p = html.find("<img ", p + 1)) {
    ++images;
    EXPECT_EQ(html.compare(html.find("src=\"", p) + 5, 22, "data:image/png;base64,"), 0);
  }
  EXPECT_EQ(images, 2u + 3u * 2u);
  // The heat-map legends name the shared scale.
  float scale = comparison_heatmap_scale(c, {});
  EXPECT_GT(scale, 0);
  EXPECT_LE(scale, 1);
  EXPECT_EQ(comparison_heatmap_scale(c, ReportOptions{0.25f}), 0.25f);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
