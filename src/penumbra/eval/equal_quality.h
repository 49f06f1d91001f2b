// Equal-quality speed-ups (issue 14 part 3): for each method of a comparison, how many light
// samples the `reference` (ray tracing on Embree) needs to reach the method's error against
// the ground truth, and what that reference render costs. The reference is rendered at 1, 2,
// 4, 8, ... light samples (the *ladder*, once per scene and setting, shared by every method,
// cached beside the ground truth) and the method's error is placed between the two rungs
// that bracket it, interpolating log(samples) and log(time) linearly in log(error)
// (docs/compare.md, "Equal quality").
#pragma once

#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "penumbra/eval/reference_cache.h"
#include "penumbra/eval/run_setup.h"

namespace penumbra {

class Progress;

// One rung: the reference at `light_samples`, with ladder_seed(seed), against the ground truth.
struct LadderRung {
  int light_samples = 0;
  double v_mae = std::numeric_limits<double>::quiet_NaN();  // mean |dV|
  double flip = std::numeric_limits<double>::quiet_NaN();   // mean FLIP of the colour image
  double shadow_ms = 0;                 // total - camera pass - compose, median of the runs
  double total_ms = 0, camera_pass_ms = 0;
  std::vector<double> run_shadow_ms;    // every timed run (of the render that timed it)
  bool from_cache = false;              // its errors came from the cache
  TimeBasis time_basis = TimeBasis::kMeasuredNow;  // where its times come from
  std::string key;                      // its cache key
};

struct ReferenceLadder {
  uint64_t seed = 0;                    // ladder_seed(the run's seed)
  int max_samples = 0;                  // the largest rung allowed: the ground truth's samples
  std::vector<LadderRung> rungs;        // 1, 2, 4, ... light samples, as far as was needed
};

// Renders (or loads from `cache_dir`) the rungs 1, 2, 4, ... up to the ground truth's light
// samples, stopping after the first rung whose mean |dV| is at most `target_v` and whose FLIP
// is at most `target_flip` (the best of the compared methods; NaN: no condition). `runs`
// timed renders (median) after `warmup_runs` untimed ones per rung rendered. A cached rung
// whose times another machine or thread count measured is rendered again for its times alone
// (issue 32; reference_cache.h, TimingOrigin), which the entry then records beside the others.
ReferenceLadder render_reference_ladder(const RunSetup& setup, const Scene& scene, const GroundTruth& truth,
                                        double target_v, double target_flip, const std::filesystem::path& cache_dir,
                                        int runs = 1, int warmup_runs = 0, Progress* progress = nullptr);

// Where a method's error lies against the ladder.
enum class QualityBound {
  kNone,     // no number: no ladder, or the method's error is undefined
  kExact,    // interpolated between two rungs (or equal to the first rung)
  kAtLeast,  // the method beats every rung: the reference needs at least `samples`
  kAtMost,   // even one light sample of the reference is at least as good: at most `samples` (1)
};
const char* bound_name(QualityBound b);  // "exact", "at_least", "at_most", "none"

struct EqualQuality {
  QualityBound bound = QualityBound::kNone;
  double samples = std::numeric_limits<double>::quiet_NaN();       // reference light samples
  double reference_ms = std::numeric_limits<double>::quiet_NaN();  // the reference's shadow time there
  double speedup = std::numeric_limits<double>::quiet_NaN();       // reference_ms / the method's shadow time
};

// A rung as the search sees it: light samples, error (V or FLIP), shadow time.
struct LadderPoint {
  double samples = 0, error = 0, ms = 0;
};

// y at x on the straight line through (x0, y0) and (x1, y1) in log-log coordinates:
// y0 * (y1/y0)^(log(x/x0) / log(x1/x0)). All arguments > 0 and x0 != x1.
double interpolate_log_log(double x0, double y0, double x1, double y1, double x);

// The equal-quality point of a method with `error` and `method_ms` on `ladder` (ascending
// samples). The first rung whose error is at most the method's and the rung before it
// bracket the method; samples and time are interpolated log-log in the error between them
// (linearly when an error is 0). No rung reaches the method: kAtLeast with the last rung;
// the first rung already does: kAtMost with it (kExact when equal).
EqualQuality equal_quality_search(const std::vector<LadderPoint>& ladder, double error, double method_ms);

// The ladder's points for one metric: "v_mae" or "flip".
std::vector<LadderPoint> ladder_points(const ReferenceLadder& ladder, const std::string& metric);

}  // namespace penumbra
