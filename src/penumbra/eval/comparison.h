// A comparison: every chosen shadow method rendered on one scene and measured against the
// ground truth (the reference at many light samples, cached): V errors, colour PSNR and
// FLIP, time per phase, speed ratio, rays traced and memory. A method that throws is
// recorded with its message and the others still run. Used by `penumbra compare`, `sweep`
// and `bench`; written out as index.html, results.json and results.csv (docs/compare.md).
#pragma once

#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/core/image.h"
#include "penumbra/eval/equal_quality.h"
#include "penumbra/eval/metrics.h"
#include "penumbra/eval/object_errors.h"
#include "penumbra/eval/reference_cache.h"
#include "penumbra/eval/run_setup.h"
#include "penumbra/shadow/stats.h"

namespace penumbra {

class Progress;
struct RenderResult;
struct RenderSettings;

struct CompareOptions {
  std::vector<std::string> methods;  // names or method specs (expand_method_list)
  bool ground_truth = true;          // false: timings only, no error metrics
  std::filesystem::path cache_dir;   // reference cache; empty: always render it
  int runs = 1;                      // timed renders per method; the median is reported
  int warmup_runs = 0;               // untimed renders per method before the timed ones
  // Run i of every method before run i+1 of any (method A, B, C, A, B, C, ...) instead of all
  // runs of one method in a row: ratios between methods are then measured side by side, and
  // a change of the machine's load during the comparison reaches every method alike.
  bool interleave = false;
  // With a ground truth: render the reference ladder (1, 2, 4, ... light samples, cached) and
  // give each method its equal-quality point (eval/equal_quality.h).
  bool equal_quality = true;
  bool keep_images = true;           // keep each method's colour and V images
  bool progress = false;             // one progress bar on stderr over the whole comparison
  // A bar owned by the caller (a sweep over several comparisons); overrides `progress`.
  Progress* progress_bar = nullptr;
  // `compare --objects`: patterns over object names, each a group of pixels whose V error every
  // method also gets on its own (object_errors.h); with a ground truth only.
  std::vector<std::string> objects;
};

// Times of one render (ms). shadow = total - camera pass - compose: what the method itself
// costs (prepare + evaluate), the part that differs between methods.
struct RenderTimes {
  double total_ms = 0;
  double camera_pass_ms = 0;
  double shadow_ms = 0;
};

struct MethodRun {
  std::string method;           // its label in the --methods list ("pcss:variant=xie2007")
  bool ok = false;
  std::string error;            // the exception's message when !ok
  nlohmann::json params;        // resolved parameters
  int light_samples = 0;        // --spp when the method samples the light, else 0
  Image color, visibility;      // when keep_images
  RenderTimes times;            // of the median run (by shadow_ms)
  std::vector<double> run_shadow_ms;  // every timed run
  std::vector<double> run_total_ms;   // every timed run: the whole render
  std::vector<std::vector<std::pair<std::string, double>>> run_phases_ms;  // every timed run
  MethodStats stats;            // of the median run: phases, rays, memory, extra
  nlohmann::json tracer;        // of the median run: its Embree scene (RenderResult::tracer)
  size_t view_samples = 0;
  // Against the ground truth (NaN without one).
  ErrorStats v;                         // on V
  std::vector<ErrorStats> v_objects;    // on V over each of Comparison::object_groups' pixels
  double color_psnr = std::numeric_limits<double>::quiet_NaN();  // dB, displayed (sRGB) colour
  double flip = std::numeric_limits<double>::quiet_NaN();        // mean FLIP of the colour image
  double speedup = std::numeric_limits<double>::quiet_NaN();     // basis shadow_ms / this shadow_ms
  // At equal quality (with a reference ladder): the reference's light samples and time where
  // its mean |dV| (eq_v) or FLIP (eq_flip) equals this method's, and the speed-up over it.
  EqualQuality eq_v, eq_flip;
};

// One method over the frames of an animated scene (`compare --frame-range`, eval/temporal.h);
// the per-frame vectors hold the frames [FrameSequence::begin, end) in order.
struct MethodFrames {
  std::string method;  // its label, as in Comparison::runs
  bool ok = false;
  std::string error;   // the first failure's message, naming the frame, when !ok
  std::vector<double> v_mae;            // mean |dV| against each frame's own ground truth
  std::vector<double> shadow_ms_fresh;  // each frame rendered from nothing (median of --runs)
  std::vector<double> shadow_ms_reuse;  // one Renderer over the sequence (reuse across frames)
  std::vector<double> flicker;          // frame_flicker of frames t-1 -> t, t > begin
  double v_mae_mean = std::numeric_limits<double>::quiet_NaN();
  double temporal_instability = std::numeric_limits<double>::quiet_NaN();  // mean of flicker
  double ms_per_frame_fresh = std::numeric_limits<double>::quiet_NaN();
  double ms_per_frame_reuse = std::numeric_limits<double>::quiet_NaN();
  std::vector<Image> color;  // each frame's colour image (with keep_images; not in results.json)
};

struct FrameSequence {
  int begin = 0, end = 0;             // frames [begin, end)
  float fps = 24;                     // the animation's, for playing the sequence in the page
  std::vector<Image> truth_color;     // each frame's ground truth (with keep_images; not in results.json)
  std::vector<bool> truth_cached;     // per frame: its ground truth came from the cache
  std::vector<MethodFrames> methods;  // in the order of Comparison::runs
};

struct Comparison {
  std::string scene;            // the scene file
  std::string description;      // the scene's "description"
  int width = 0, height = 0, pixel_samples = 1;
  size_t triangles = 0, lights = 0;
  double load_ms = 0;           // the scene's load (run_comparison: parsing, mesh import, generators)
  int light_samples = 0, reference_samples = 0;
  uint64_t seed = 0;
  std::vector<std::string> params;  // the run's method parameter settings
  bool has_ground_truth = false;
  GroundTruth truth;
  std::vector<ObjectGroup> object_groups;  // CompareOptions::objects (their masks not in results.json)
  bool has_ladder = false;
  ReferenceLadder ladder;       // the reference at 1, 2, 4, ... light samples (equal quality)
  std::vector<MethodRun> runs;  // in the order of CompareOptions::methods
  // What speedup divides: "reference" (the reference method at --spp in this run) or
  // "ground truth" (the ground truth's render, when `reference` is not compared).
  std::string speedup_basis;
  double speedup_basis_ms = 0;
  // Where speedup_basis_ms comes from (issue 32): measured now, or from the cache where this
  // machine measured it with this thread count. A time from another machine or thread count
  // (kCachedElsewhere) is no basis: the speed-ups are then left out.
  TimeBasis speedup_time_basis = TimeBasis::kMeasuredNow;
  nlohmann::json machine;       // machine_json()
  std::string started;          // local time, ISO 8601
  double wall_ms = 0;
  std::string command;          // the command line, set by the CLI
  // With --frame-range: the sequence (the rest of the comparison is its first frame's).
  bool has_frames = false;
  FrameSequence frames;
};

Comparison run_comparison(const RunSetup& setup, const CompareOptions& options);

// --- A comparison in steps: what run_comparison does in one process, and what
// penumbra.distributed (docs/distributed.md) runs as separate jobs on a cluster: the ground
// truth once per scene and setting, shared by the jobs of every method; each method; then the
// reference ladder and the speed ratios once every method is in.
// The settings and sizes of a comparison, without ground truth or methods.
Comparison comparison_header(const RunSetup& setup, const Scene& scene);
// One --methods entry rendered options.warmup_runs + options.runs times in a row, measured
// against `truth` (null: no error metrics); a method that throws gives ok = false with its
// message. `progress` (optional) is advanced while rendering.
MethodRun compare_method(const RunSetup& setup, const Scene& scene, const std::string& label, const GroundTruth* truth,
                         const CompareOptions& options, Progress* progress = nullptr);
// The groups of `--objects` as results.json and the bench's JSON hold them: pattern, objects
// matched, pixels (no masks).
nlohmann::json object_groups_json(const std::vector<ObjectGroup>& groups);
// A method's error columns (V errors, colour PSNR, FLIP) from its first render's images:
// compare_method does it when given the ground truth; penumbra.distributed renders a method
// while the ground truth is still being rendered elsewhere, and measures it after.
void measure_against_truth(MethodRun& run, const Image& color, const Image& visibility, const GroundTruth& truth);
// The reference ladder of c's methods (rendered as far as the best of them needs), or none
// without a ground truth, with options.equal_quality off or when no method has an error.
std::optional<ReferenceLadder> comparison_ladder(const Comparison& c, const RunSetup& setup, const Scene& scene,
                                                 const CompareOptions& options, Progress* progress = nullptr);
// Sets c's ladder and every method's equal-quality points on it.
void apply_ladder(Comparison& c, ReferenceLadder ladder);
// Every method's speedup: against `reference` when it was compared, else the ground truth's
// render, whose time must be this machine's at this thread count (time_ground_truth): a time
// from elsewhere gives no speed-ups.
void apply_speedups(Comparison& c);
// Whether the speed-ups divide the ground truth's time: no `reference` among c's methods ran.
bool speedups_over_ground_truth(const Comparison& c);
// The basis of each kind of speed-up in words, for the terminal and the page: "reference at
// 256 light samples in this run (time measured now)", "the ground truth's render at 1024 light
// samples (time from the cache, same machine and threads)"; empty without speed-ups.
std::string speedup_basis_text(const Comparison& c);
// The methods whose mean |dV| exceeds `hard`'s in this comparison, in run order (issue 34's
// wide-scene line: a map method should not lose to the exact hard shadow); empty without a
// ground truth or without a successful `hard` run.
std::vector<std::string> worse_than_hard(const Comparison& c);
// Where the ladder's times come from: "measured now", "from the cache, same machine and
// threads", or per group of rungs ("1, 2, 4 spp from the cache, same machine and threads; 8 spp
// measured now").
std::string ladder_time_basis_text(const ReferenceLadder& ladder);
// The render settings of one --methods entry: its method, parameters, light samples and seed.
RenderSettings method_render_settings(const RunSetup& setup, const std::string& label);
// A render's shadow time: total - camera pass - compose (the method's prepare + evaluate).
double shadow_time_ms(const RenderResult& r);
// The median (the lower one of an even count); 0 for none.
double median_of(std::vector<double> v);
// Shadow rays traced per view sample (over all lights): agrawala2000's "average rays
// traced" per shading point; NaN when there are no view samples.
double rays_per_view_sample(const MethodRun& r);
// The progress units run_comparison() will report: a caller that passes its own bar
// (options.progress_bar) sets the bar's total to the sum over its comparisons.
uint64_t comparison_progress_units(const RunSetup& setup, const CompareOptions& options);

// The colour image as displayed: linear radiance clamped to [0,1] and sRGB-encoded (what
// the PNG shows); PSNR of colour images is computed on these values.
Image display_srgb(const Image& linear);

// CPU model, logical cores, worker threads, compiler, build type.
nlohmann::json machine_json();
// The most resident memory this process has held so far (getrusage's ru_maxrss), in bytes.
uint64_t peak_rss_bytes();
// A number for JSON: finite as is, +/-infinity as "inf"/"-inf", NaN as null.
nlohmann::json json_number(double v);
// Local time now, "2024-05-01T12:34:56".
std::string local_time_iso();

// results.json: the settings, the ground truth and one object per method.
nlohmann::json comparison_json(const Comparison& c);
// results.json back into a Comparison (without images): the inverse of comparison_json for
// everything it holds. One method's entry, the ground truth's and the ladder's alone (the
// parts penumbra.distributed's jobs return) have their own pairs.
Comparison comparison_from_json(const nlohmann::json& j);
nlohmann::json method_run_json(const MethodRun& r);
MethodRun method_run_from_json(const nlohmann::json& j);
nlohmann::json ground_truth_json(const GroundTruth& t);
GroundTruth ground_truth_from_json(const nlohmann::json& j);
nlohmann::json reference_ladder_json(const ReferenceLadder& ladder);
ReferenceLadder reference_ladder_from_json(const nlohmann::json& j);
nlohmann::json frame_sequence_json(const FrameSequence& f);
FrameSequence frame_sequence_from_json(const nlohmann::json& j);
// results.csv: one row per method (phase columns: the union of the methods' phases).
std::string comparison_csv(const Comparison& c);

struct ReportOptions {
  // Scale of the V error heat maps, shared by every method so they compare at a glance;
  // 0: automatic: the lower median over the methods of each one's 99th percentile of
  // |dV|, rounded up to 1, 2 or 5 x 10^k.
  float heatmap_scale = 0;
  bool write_images = true;  // also DIR/images/<method>.exr (colour + V) for `penumbra diff`
};

// The file name of a method's image under DIR/images/: its label with characters other
// than letters, digits and "-_.=" replaced by '_' ("pcss:variant=xie2007" ->
// "pcss_variant=xie2007").
std::string image_file_stem(const std::string& label);
// Writes DIR/index.html, DIR/results.json, DIR/results.csv (and DIR/images/). Creates DIR.
void write_comparison(const Comparison& c, const std::filesystem::path& dir, const ReportOptions& options = {});

// The error-time chart (report_html.cpp): `metric` ("v_mae" or "flip", log) against the shadow
// time (log), every method a point and the reference ladder a curve, its rungs labelled by
// their light samples. The methods are the same points whether there is a ladder or not.
std::string error_time_svg(const Comparison& c, const std::string& metric);
// With a sequence (compare --frame-range): each method's mean |ΔV| ("v_mae") or shadow time
// ("shadow_ms": with reuse a line, from nothing markers) against the frame.
std::string frames_svg(const Comparison& c, const std::string& what);

// The self-contained HTML page (report_html.cpp).
std::string comparison_html(const Comparison& c, const ReportOptions& options = {});
// The heat-map scale the page uses for `options` (the automatic one when 0).
float comparison_heatmap_scale(const Comparison& c, const ReportOptions& options);

}  // namespace penumbra
