#include "penumbra/eval/equal_quality.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "penumbra/core/interrupt.h"
#include "penumbra/core/progress.h"
#include "penumbra/eval/comparison.h"
#include "penumbra/eval/flip.h"
#include "penumbra/eval/metrics.h"
#include "penumbra/render/renderer.h"

namespace penumbra {

using nlohmann::json;

namespace {

// A rung's times, as a cache entry's "timings" keep them.
json rung_times_json(const LadderRung& r) {
  return {{"shadow_ms", r.shadow_ms},
          {"total_ms", r.total_ms},
          {"camera_pass_ms", r.camera_pass_ms},
          {"run_shadow_ms", r.run_shadow_ms}};
}

// A cached rung: its errors, and the times this machine measured with these threads, else the
// newest record's (kCachedElsewhere). Throws on a damaged entry.
LadderRung rung_from_json(const json& e) {
  LadderRung r;
  r.light_samples = e.at("spp").get<int>();
  r.v_mae = e.at("v_mae").is_number() ? e["v_mae"].get<double>() : std::nan("");
  r.flip = e.at("flip").is_number() ? e["flip"].get<double>() : std::nan("");
  json t = find_timing(e, current_timing_origin());
  r.time_basis = TimeBasis::kCachedHere;
  if (t.is_null()) {
    t = e.at("timings").at(e.at("timings").size() - 1);
    r.time_basis = TimeBasis::kCachedElsewhere;
  }
  r.shadow_ms = t.at("shadow_ms").get<double>();
  r.total_ms = t.at("total_ms").get<double>();
  r.camera_pass_ms = t.at("camera_pass_ms").get<double>();
  r.run_shadow_ms = t.at("run_shadow_ms").get<std::vector<double>>();
  r.from_cache = true;
  return r;
}

// The rung at `samples` rendered warmup_runs + runs times: its times, and its errors against
// `truth` (from the first render) when `measure` (a re-timing of a cached rung keeps the
// cached errors, the same numbers).
LadderRung render_rung(const RunSetup& setup, const Scene& scene, const GroundTruth& truth, int samples, int runs,
                       int warmup_runs, Progress* progress, bool measure = true) {
  RenderSettings settings;
  settings.method = "reference";
  // The ground truth's own parameters: the ladder is the ground truth at fewer samples.
  settings.params = setup.overrides_for("reference", /*explicit_only=*/true);
  settings.light_samples = samples;
  settings.seed = ladder_seed(setup.seed);
  settings.progress_bar = progress;
  LadderRung rung;
  rung.light_samples = samples;
  std::vector<double> totals, cameras;
  const int renders = std::max(0, warmup_runs) + std::max(1, runs);
  for (int i = 0; i < renders; ++i) {
    RenderResult r = render_scene(scene, settings);
    if (i == 0 && measure) {
      rung.v_mae = compare_images(r.visibility, truth.visibility).mae;
      rung.flip = flip(r.color, truth.color).mean;
    }
    if (i < std::max(0, warmup_runs)) continue;
    rung.run_shadow_ms.push_back(shadow_time_ms(r));
    totals.push_back(r.total_ms);
    cameras.push_back(r.camera_pass_ms);
  }
  rung.shadow_ms = median_of(rung.run_shadow_ms);
  // The total and camera pass of the run whose shadow time is the median.
  for (size_t i = 0; i < rung.run_shadow_ms.size(); ++i)
    if (rung.run_shadow_ms[i] == rung.shadow_ms) {
      rung.total_ms = totals[i];
      rung.camera_pass_ms = cameras[i];
    }
  return rung;
}

}  // namespace

ReferenceLadder render_reference_ladder(const RunSetup& setup, const Scene& scene, const GroundTruth& truth,
                                        double target_v, double target_flip, const std::filesystem::path& cache_dir,
                                        int runs, int warmup_runs, Progress* progress) {
  ReferenceLadder ladder;
  ladder.seed = ladder_seed(setup.seed);
  ladder.max_samples = truth.light_samples;
  for (int n = 1; n <= ladder.max_samples; n *= 2) {
    const std::string key = ladder_rung_key(setup, n);
    LadderRung rung;
    json cached = load_ladder_rung(cache_dir, key);
    bool loaded = false;
    if (!cached.is_null()) {
      try {
        rung = rung_from_json(cached);
        loaded = rung.light_samples == n;
      } catch (const Interrupted&) {
        throw;  // Ctrl-C ends the run, whatever this step would do with an error
      } catch (const std::exception&) {
        loaded = false;  // damaged: rendered again below
      }
    }
    if (!loaded || rung.time_basis == TimeBasis::kCachedElsewhere) {
      if (progress) {
        // Rungs are rendered as far as needed: their units join the bar as they start.
        const uint64_t units = static_cast<uint64_t>(scene.camera.width) * scene.camera.height *
                               std::max(1, scene.camera.samples_per_pixel) * std::max<size_t>(1, scene.lights.size()) *
                               (std::max(0, warmup_runs) + std::max(1, runs));
        progress->set_total(progress->total() + units);
        progress->set_label(fmt::format("compare: reference ladder, {} light samples{}", n,
                                        loaded ? " (timing it on this machine)" : ""));
      }
      const LadderRung fresh = render_rung(setup, scene, truth, n, runs, warmup_runs, progress, /*measure=*/!loaded);
      json entry = cached;
      if (loaded) {
        // Only the times are new: the errors (and the images they come from) are the cached ones.
        rung.shadow_ms = fresh.shadow_ms;
        rung.total_ms = fresh.total_ms;
        rung.camera_pass_ms = fresh.camera_pass_ms;
        rung.run_shadow_ms = fresh.run_shadow_ms;
      } else {
        rung = fresh;
        entry = {{"spp", n},
                 {"seed", ladder.seed},
                 {"v_mae", json_number(rung.v_mae)},
                 {"flip", json_number(rung.flip)},
                 {"ground_truth_key", truth.key},
                 {"scene", setup.scene_path.string()}};
      }
      rung.time_basis = TimeBasis::kMeasuredNow;
      put_timing(entry, current_timing_origin(), rung_times_json(rung));
      store_ladder_rung(cache_dir, key, entry);
    }
    rung.key = key;
    ladder.rungs.push_back(rung);
    const bool v_reached = std::isnan(target_v) || rung.v_mae <= target_v;
    const bool flip_reached = std::isnan(target_flip) || rung.flip <= target_flip;
    if (v_reached && flip_reached) break;
  }
  return ladder;
}

const char* bound_name(QualityBound b) {
  switch (b) {
    case QualityBound::kExact: return "exact";
    case QualityBound::kAtLeast: return "at_least";
    case QualityBound::kAtMost: return "at_most";
    case QualityBound::kNone: break;
  }
  return "none";
}

double interpolate_log_log(double x0, double y0, double x1, double y1, double x) {
  const double t = std::log(x / x0) / std::log(x1 / x0);
  return y0 * std::pow(y1 / y0, t);
}

EqualQuality equal_quality_search(const std::vector<LadderPoint>& ladder, double error, double method_ms) {
  EqualQuality q;
  if (ladder.empty() || !std::isfinite(error)) return q;
  // The first rung at least as good as the method.
  size_t k = 0;
  while (k < ladder.size() && !(ladder[k].error <= error)) ++k;
  if (k == ladder.size()) {
    q.bound = QualityBound::kAtLeast;
    q.samples = ladder.back().samples;
    q.reference_ms = ladder.back().ms;
  } else if (k == 0) {
    q.bound = ladder[0].error == error ? QualityBound::kExact : QualityBound::kAtMost;
    q.samples = ladder[0].samples;
    q.reference_ms = ladder[0].ms;
  } else {
    const LadderPoint& a = ladder[k - 1];  // error above the method's
    const LadderPoint& b = ladder[k];      // error at or below it
    q.bound = QualityBound::kExact;
    // Errors of Monte Carlo estimates fall as a power of the sample count, and times grow
    // about linearly with it: both are straight lines between rungs in log-log. An error of 0
    // has no logarithm: linear in the error then.
    if (a.error > 0 && b.error > 0 && error > 0) {
      q.samples = interpolate_log_log(a.error, a.samples, b.error, b.samples, error);
      q.reference_ms = a.ms > 0 && b.ms > 0 ? interpolate_log_log(a.error, a.ms, b.error, b.ms, error)
                                            : a.ms + (b.ms - a.ms) * (a.error - error) / (a.error - b.error);
    } else {
      const double f = (a.error - error) / (a.error - b.error);
      q.samples = a.samples + f * (b.samples - a.samples);
      q.reference_ms = a.ms + f * (b.ms - a.ms);
    }
  }
  if (method_ms > 0 && q.reference_ms > 0) q.speedup = q.reference_ms / method_ms;
  return q;
}

std::vector<LadderPoint> ladder_points(const ReferenceLadder& ladder, const std::string& metric) {
  std::vector<LadderPoint> points;
  for (const LadderRung& r : ladder.rungs)
    points.push_back({static_cast<double>(r.light_samples), metric == "flip" ? r.flip : r.v_mae, r.shadow_ms});
  return points;
}

}  // namespace penumbra
