#include "penumbra/eval/comparison.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <ctime>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <sys/resource.h>

#include "penumbra/core/file_util.h"
#include "penumbra/core/huge_pages.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/program_identity.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/eval/report_util.h"
#include "penumbra/eval/flip.h"
#include "penumbra/render/renderer.h"

namespace penumbra {

namespace fs = std::filesystem;
using nlohmann::json;

Image display_srgb(const Image& linear) {
  Image out = linear;
  for (float& v : out.data()) v = linear_to_srgb(v);  // clamps to [0,1]
  return out;
}

json json_number(double v) {
  if (std::isnan(v)) return nullptr;
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

std::string local_time_iso() {
  std::time_t t = std::time(nullptr);
  std::tm tm{};
  localtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return buf;
}

json machine_json() {
  const std::string cpu = cpu_model();
#ifdef NDEBUG
  const char* build = "Release (NDEBUG)";
#else
  const char* build = "Debug (asserts on)";
#endif
  return {{"cpu", cpu},
          {"logical_cores", std::thread::hardware_concurrency()},
          {"threads", max_threads()},
          {"compiler", fmt::format("g++ {}", __VERSION__)},
          {"build", build},
          // The heap on 2 MiB pages (core/huge_pages.h): a fifth of a wide scene's time.
          {"huge_pages", heap_uses_huge_pages()}};
}

uint64_t peak_rss_bytes() {
  struct rusage usage {};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return static_cast<uint64_t>(usage.ru_maxrss) * 1024;  // KiB on Linux
}

namespace {

// A comparison's progress: each render is given a budget of view samples x lights (the
// most the renderer can report); what it did not report is added when it finishes.
class Budget {
 public:
  explicit Budget(Progress* p) : p_(p) {}
  void begin(const std::string& label, uint64_t units) {
    if (!p_) return;
    p_->set_label(label);
    target_ += units;
  }
  void end() {
    if (p_ && p_->done() < target_) p_->add(target_ - p_->done());
  }

 private:
  Progress* p_;
  uint64_t target_ = 0;
};

uint64_t render_units(const RunSetup& setup) {
  size_t lights = setup.scene_doc.contains("lights") && setup.scene_doc["lights"].is_array()
                      ? setup.scene_doc["lights"].size()
                      : 1;
  return static_cast<uint64_t>(setup.width()) * setup.height() * std::max(1, setup.pixel_samples()) *
         std::max<size_t>(1, lights);
}

}  // namespace

RenderSettings method_render_settings(const RunSetup& setup, const std::string& label) {
  const MethodSpec spec = parse_method_spec(label);
  RenderSettings settings;
  settings.method = spec.name;
  settings.params = setup.overrides_for(spec);
  settings.light_samples = setup.light_samples;
  settings.seed = setup.seed;
  settings.device = gpu::DeviceChoice::parse(spec.device.empty() ? setup.device : spec.device);
  return settings;
}

double shadow_time_ms(const RenderResult& r) {
  // On a GPU the method's own stages, timed on the device (its phases are GPU times; the wall
  // time also holds the submission and the read-back).
  if (r.gpu_ms.is_object()) return std::max(0.0, r.stats.total_ms() - r.stats.phase("compose"));
  return std::max(0.0, r.total_ms - r.camera_pass_ms - r.stats.phase("compose"));
}

double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[(v.size() - 1) / 2];
}

uint64_t comparison_progress_units(const RunSetup& setup, const CompareOptions& options) {
  const int runs = std::max(1, options.runs) + std::max(0, options.warmup_runs);
  const bool truth_render = options.ground_truth && !ground_truth_cached(setup, options.cache_dir);
  return render_units(setup) * (options.methods.size() * runs + (truth_render ? 1 : 0));
}

namespace {

// The renders of one method, in the order made (warm-ups first), or its error.
struct MethodRenders {
  MethodRun run;
  RenderSettings settings;
  std::vector<RenderResult> results;
  bool failed = false;
};

MethodRenders method_renders(const RunSetup& setup, const std::string& label, Progress* bar) {
  MethodRenders p;
  p.run.method = label;
  p.settings = method_render_settings(setup, label);
  p.run.light_samples = MethodRegistry::get(p.settings.method).samples_light ? setup.light_samples : 0;
  p.settings.progress_bar = bar;
  return p;
}

// Render i of a method (`first` when its images are kept: they are the same every run).
void render_once(MethodRenders& p, const Scene& scene, bool first) {
  if (p.failed) return;  // a run that will not happen counts as done
  try {
    p.results.push_back(render_scene(scene, p.settings));
  } catch (const Interrupted&) {
    throw;  // Ctrl-C ends the run, whatever this step would do with an error
  } catch (const std::exception& e) {
    p.failed = true;
    p.run.error = e.what();
    p.results.clear();
  }
  if (!p.failed && !first) {
    p.results.back().color = Image();
    p.results.back().visibility = Image();
  }
}

// The method's row from its renders: the median run's times and statistics, the first
// run's images measured against the ground truth.
MethodRun summarize(MethodRenders& p, const GroundTruth* truth, const CompareOptions& options,
                    const std::vector<ObjectGroup>& groups = {}) {
  MethodRun run = std::move(p.run);
  if (p.failed) {
    run.ok = false;
    run.v.mae = run.v.rmse = run.v.max_abs = run.v.mean_signed = run.v.psnr = std::numeric_limits<double>::quiet_NaN();
    return run;
  }
  std::vector<RenderResult>& results = p.results;
  // Warm-up renders are dropped (the first of them holds the images).
  const int warmups = std::max(0, options.warmup_runs);
  if (warmups > 0) {
    Image color = std::move(results.front().color), vis = std::move(results.front().visibility);
    results.erase(results.begin(), results.begin() + warmups);
    results.front().color = std::move(color);
    results.front().visibility = std::move(vis);
  }
  std::vector<double> times;
  for (const auto& r : results) {
    times.push_back(shadow_time_ms(r));
    run.run_total_ms.push_back(r.total_ms);
    run.run_phases_ms.push_back(r.stats.phases_ms);
  }
  double med = median_of(times);
  size_t pick = 0;
  for (size_t i = 0; i < results.size(); ++i)
    if (times[i] == med) pick = i;
  const RenderResult& m = results[pick];
  run.times = {m.total_ms, m.camera_pass_ms, med};
  run.run_shadow_ms = times;
  run.stats = m.stats;
  run.tracer = m.tracer;
  run.params = m.resolved_params;
  run.view_samples = m.view_sample_count;
  RenderResult& first = results.front();
  if (truth) {
    measure_against_truth(run, first.color, first.visibility, *truth);
    run.v_objects = object_errors(first.visibility, truth->visibility, groups);
  } else {
    run.v.mae = run.v.rmse = run.v.max_abs = run.v.mean_signed = std::numeric_limits<double>::quiet_NaN();
    run.v.psnr = std::numeric_limits<double>::quiet_NaN();
  }
  if (options.keep_images) {
    run.color = std::move(first.color);
    run.visibility = std::move(first.visibility);
  }
  run.ok = true;
  results.clear();
  return run;
}

}  // namespace

void measure_against_truth(MethodRun& run, const Image& color, const Image& visibility, const GroundTruth& truth) {
  run.v = compare_images(visibility, truth.visibility);
  run.color_psnr = compare_images(display_srgb(color), display_srgb(truth.color)).psnr;
  run.flip = flip(color, truth.color).mean;
}

Comparison comparison_header(const RunSetup& setup, const Scene& scene) {
  Comparison c;
  c.started = local_time_iso();
  c.machine = machine_json();
  c.scene = setup.scene_path.string();
  c.description = setup.scene_doc.value("description", "");
  c.light_samples = setup.light_samples;
  c.reference_samples = setup.reference_samples;
  c.seed = setup.seed;
  c.params = setup.method_params;
  c.width = scene.camera.width;
  c.height = scene.camera.height;
  c.pixel_samples = scene.camera.samples_per_pixel;
  c.triangles = scene.triangle_count();
  c.lights = scene.lights.size();
  return c;
}

MethodRun compare_method(const RunSetup& setup, const Scene& scene, const std::string& label, const GroundTruth* truth,
                         const CompareOptions& options, Progress* progress) {
  MethodRenders p = method_renders(setup, label, progress);
  const int runs = std::max(1, options.runs) + std::max(0, options.warmup_runs);
  for (int i = 0; i < runs; ++i) render_once(p, scene, i == 0);
  return summarize(p, truth, options);
}

std::optional<ReferenceLadder> comparison_ladder(const Comparison& c, const RunSetup& setup, const Scene& scene,
                                                 const CompareOptions& options, Progress* progress) {
  if (!c.has_ground_truth || !options.equal_quality) return std::nullopt;
  // Rendered as far as the best method needs.
  double best_v = std::numeric_limits<double>::quiet_NaN(), best_flip = best_v;
  for (const MethodRun& r : c.runs) {
    if (!r.ok) continue;
    if (std::isfinite(r.v.mae) && !(r.v.mae >= best_v)) best_v = r.v.mae;
    if (std::isfinite(r.flip) && !(r.flip >= best_flip)) best_flip = r.flip;
  }
  if (!std::isfinite(best_v) && !std::isfinite(best_flip)) return std::nullopt;
  return render_reference_ladder(setup, scene, c.truth, best_v, best_flip, options.cache_dir, options.runs,
                                 options.warmup_runs, progress);
}

void apply_ladder(Comparison& c, ReferenceLadder ladder) {
  c.ladder = std::move(ladder);
  c.has_ladder = true;
  const std::vector<LadderPoint> v_points = ladder_points(c.ladder, "v_mae");
  const std::vector<LadderPoint> flip_points = ladder_points(c.ladder, "flip");
  for (MethodRun& r : c.runs) {
    if (!r.ok) continue;
    r.eq_v = equal_quality_search(v_points, r.v.mae, r.times.shadow_ms);
    r.eq_flip = equal_quality_search(flip_points, r.flip, r.times.shadow_ms);
  }
}

bool speedups_over_ground_truth(const Comparison& c) {
  for (const MethodRun& r : c.runs)
    if (r.method == "reference" && r.ok) return false;
  return true;
}

void apply_speedups(Comparison& c) {
  // Against the reference method at the same spp when it was compared, else against the
  // ground truth's own render.
  c.speedup_basis.clear();
  c.speedup_basis_ms = 0;
  c.speedup_time_basis = TimeBasis::kMeasuredNow;
  for (const MethodRun& r : c.runs)
    if (r.method == "reference" && r.ok) {
      c.speedup_basis = "reference";
      c.speedup_basis_ms = r.times.shadow_ms;
    }
  if (c.speedup_basis.empty() && c.has_ground_truth) {
    double compose = 0;
    if (c.truth.stats.contains("phases_ms") && c.truth.stats["phases_ms"].contains("compose"))
      compose = c.truth.stats["phases_ms"]["compose"].get<double>();
    c.speedup_basis = "ground truth";
    c.speedup_basis_ms = std::max(0.0, c.truth.total_ms - c.truth.camera_pass_ms - compose);
    c.speedup_time_basis = c.truth.time_basis;
  }
  // Another machine's or thread count's time divided by this run's would mislead.
  if (c.speedup_time_basis == TimeBasis::kCachedElsewhere) return;
  for (MethodRun& r : c.runs)
    if (r.ok && !c.speedup_basis.empty() && r.times.shadow_ms > 0) r.speedup = c.speedup_basis_ms / r.times.shadow_ms;
}

std::vector<std::string> worse_than_hard(const Comparison& c) {
  std::vector<std::string> out;
  if (!c.has_ground_truth) return out;
  double hard = std::numeric_limits<double>::quiet_NaN();
  for (const MethodRun& r : c.runs)
    if (r.ok && r.method == "hard") hard = r.v.mae;
  if (!std::isfinite(hard)) return out;
  for (const MethodRun& r : c.runs)
    if (r.ok && std::isfinite(r.v.mae) && r.v.mae > hard) out.push_back(r.method);
  return out;
}

std::string speedup_basis_text(const Comparison& c) {
  if (c.speedup_basis.empty()) return "";
  const std::string what = c.speedup_basis == "reference"
                               ? fmt::format("reference at {} light samples in this run", c.light_samples)
                               : fmt::format("the ground truth's render at {} light samples", c.truth.light_samples);
  return fmt::format("{} (time {}{})", what, time_basis_text(c.speedup_time_basis),
                     c.speedup_time_basis == TimeBasis::kCachedElsewhere ? ": no speed-ups" : "");
}

std::string ladder_time_basis_text(const ReferenceLadder& ladder) {
  std::vector<std::pair<TimeBasis, std::string>> groups;  // in the order of the rungs
  for (const LadderRung& r : ladder.rungs) {
    if (groups.empty() || groups.back().first != r.time_basis) groups.emplace_back(r.time_basis, "");
    groups.back().second += (groups.back().second.empty() ? "" : ", ") + std::to_string(r.light_samples);
  }
  if (groups.size() == 1) return time_basis_text(groups[0].first);
  std::string out;
  for (const auto& [basis, spp] : groups) out += fmt::format("{}{} spp {}", out.empty() ? "" : "; ", spp, time_basis_text(basis));
  return out;
}

Comparison run_comparison(const RunSetup& setup, const CompareOptions& options) {
  Timer wall;
  if (options.methods.empty()) throw Error("compare: no methods to run");
  setup.check_plain_params(options.methods);
  Timer load;
  const Scene scene = setup.load();
  const double load_ms = load.elapsed_ms();
  Comparison c = comparison_header(setup, scene);
  c.load_ms = load_ms;
  if (!options.objects.empty()) {
    if (!options.ground_truth) throw Error("--objects: the errors by object need the ground truth");
    c.object_groups = object_groups(scene, options.objects, setup.seed);  // before any render: a typo fails at once
  }

  const int runs = std::max(1, options.runs) + std::max(0, options.warmup_runs);
  const uint64_t per_render = render_units(setup);
  const bool need_truth_render = options.ground_truth && !ground_truth_cached(setup, options.cache_dir);
  Progress own("compare", comparison_progress_units(setup, options), options.progress && !options.progress_bar);
  Progress* bar = options.progress_bar ? options.progress_bar : &own;
  Budget budget(bar);

  if (options.ground_truth) {
    budget.begin("compare: ground truth", need_truth_render ? per_render : 0);
    c.truth = ground_truth(setup, scene, options.cache_dir, bar);
    budget.end();
    c.has_ground_truth = true;
  }

  // Every method's renders, in the order of the schedule: all runs of one method in a row,
  // or (interleave) run i of every method before run i+1 of any.
  std::vector<MethodRenders> pending;
  for (const std::string& label : options.methods) pending.push_back(method_renders(setup, label, bar));
  std::vector<std::pair<size_t, int>> schedule;  // (method, render)
  if (options.interleave) {
    for (int i = 0; i < runs; ++i)
      for (size_t k = 0; k < pending.size(); ++k) schedule.emplace_back(k, i);
  } else {
    for (size_t k = 0; k < pending.size(); ++k)
      for (int i = 0; i < runs; ++i) schedule.emplace_back(k, i);
  }
  for (auto [k, i] : schedule) {
    budget.begin(fmt::format("compare: {}", pending[k].run.method), per_render);
    render_once(pending[k], scene, i == 0);
    budget.end();
  }
  for (MethodRenders& p : pending)
    c.runs.push_back(summarize(p, c.has_ground_truth ? &c.truth : nullptr, options, c.object_groups));

  if (std::optional<ReferenceLadder> ladder = comparison_ladder(c, setup, scene, options, bar))
    apply_ladder(c, std::move(*ladder));
  if (c.has_ground_truth && speedups_over_ground_truth(c) && c.truth.time_basis == TimeBasis::kCachedElsewhere) {
    // The speed-ups divide the ground truth's time: it must be this machine's, at these threads.
    bar->set_total(bar->total() + per_render);
    budget.begin("compare: timing the ground truth on this machine", per_render);
    time_ground_truth(c.truth, setup, scene, options.cache_dir, bar);
    budget.end();
  }
  own.finish();
  apply_speedups(c);
  c.wall_ms = wall.elapsed_ms();
  return c;
}

double rays_per_view_sample(const MethodRun& r) {
  return r.view_samples ? static_cast<double>(r.stats.rays_traced) / r.view_samples
                        : std::numeric_limits<double>::quiet_NaN();
}

namespace {

// json_number's inverse: null is NaN, "inf"/"-inf" are infinities.
double number_from_json(const json& j) {
  if (j.is_number()) return j.get<double>();
  if (j.is_string()) return j.get<std::string>() == "-inf" ? -std::numeric_limits<double>::infinity()
                                                           : std::numeric_limits<double>::infinity();
  return std::numeric_limits<double>::quiet_NaN();
}

QualityBound bound_from_json(const json& j) {
  if (!j.is_string()) return QualityBound::kNone;
  const std::string b = j.get<std::string>();
  return b == "exact" ? QualityBound::kExact
         : b == "at_least" ? QualityBound::kAtLeast
         : b == "at_most" ? QualityBound::kAtMost
                           : QualityBound::kNone;
}

// Phases as [[name, ms], ...]: the order they were first reported in (a JSON object's keys
// come back sorted).
json phases_json(const std::vector<std::pair<std::string, double>>& phases) {
  json out = json::array();
  for (const auto& [n, t] : phases) out.push_back({n, t});
  return out;
}

std::vector<std::pair<std::string, double>> phases_from_json(const json& j) {
  std::vector<std::pair<std::string, double>> out;
  for (const json& p : j) out.emplace_back(p.at(0).get<std::string>(), p.at(1).get<double>());
  return out;
}

}  // namespace

json method_run_json(const MethodRun& r) {
  json m = {{"method", r.method}, {"ok", r.ok}};
  if (!r.ok) {
    m["error"] = r.error;
    return m;
  }
  m["params"] = r.params;
  m["light_samples"] = r.light_samples;
  m["v_mae"] = json_number(r.v.mae);
  m["v_rmse"] = json_number(r.v.rmse);
  m["v_max"] = json_number(r.v.max_abs);
  m["v_mean_signed"] = json_number(r.v.mean_signed);
  if (!r.v_objects.empty()) {
    json objects = json::array();
    for (const ErrorStats& e : r.v_objects)
      objects.push_back({{"pixels", e.pixels},
                         {"v_mae", json_number(e.mae)},
                         {"v_rmse", json_number(e.rmse)},
                         {"v_max", json_number(e.max_abs)},
                         {"v_mean_signed", json_number(e.mean_signed)}});
    m["v_objects"] = objects;  // in the order of the comparison's object_groups
  }
  m["color_psnr"] = json_number(r.color_psnr);
  m["flip"] = json_number(r.flip);
  m["total_ms"] = r.times.total_ms;
  m["camera_pass_ms"] = r.times.camera_pass_ms;
  m["shadow_ms"] = r.times.shadow_ms;
  m["run_shadow_ms"] = r.run_shadow_ms;
  m["speedup"] = json_number(r.speedup);
  for (auto [prefix, q] : {std::pair{"eq_v", &r.eq_v}, std::pair{"eq_flip", &r.eq_flip}}) {
    const std::string p = prefix;
    m[p + "_spp"] = json_number(q->samples);
    m[p + "_bound"] = q->bound == QualityBound::kNone ? json(nullptr) : json(bound_name(q->bound));
    m[p + "_reference_ms"] = json_number(q->reference_ms);
    m[p + "_speedup"] = json_number(q->speedup);
  }
  m["run_total_ms"] = r.run_total_ms;
  m["rays_traced"] = r.stats.rays_traced;
  m["rays_per_view_sample"] = json_number(rays_per_view_sample(r));
  m["texels_visited"] = r.stats.texels_visited;
  m["memory_bytes"] = r.stats.memory_bytes;
  m["prepare_count"] = r.stats.prepare_count;
  m["view_samples"] = r.view_samples;
  json phases = json::object();
  for (const auto& [n, t] : r.stats.phases_ms) phases[n] = t;
  m["phases_ms"] = phases;
  m["phase_order"] = phases_json(r.stats.phases_ms);
  json run_phases = json::array();
  for (const auto& p : r.run_phases_ms) run_phases.push_back(phases_json(p));
  m["run_phases_ms"] = run_phases;
  m["extra"] = r.stats.extra;
  return m;
}

MethodRun method_run_from_json(const json& m) {
  MethodRun r;
  r.method = m.at("method").get<std::string>();
  r.ok = m.at("ok").get<bool>();
  if (!r.ok) {
    r.error = m.value("error", "");
    r.v.mae = r.v.rmse = r.v.max_abs = r.v.mean_signed = r.v.psnr = std::numeric_limits<double>::quiet_NaN();
    return r;
  }
  r.params = m.at("params");
  r.light_samples = m.at("light_samples").get<int>();
  r.v.mae = number_from_json(m.at("v_mae"));
  r.v.rmse = number_from_json(m.at("v_rmse"));
  r.v.max_abs = number_from_json(m.at("v_max"));
  r.v.mean_signed = number_from_json(m.at("v_mean_signed"));
  r.v.psnr = std::numeric_limits<double>::quiet_NaN();
  if (m.contains("v_objects"))
    for (const json& e : m["v_objects"]) {
      ErrorStats s;
      s.pixels = e.at("pixels").get<size_t>();
      s.mae = number_from_json(e.at("v_mae"));
      s.rmse = number_from_json(e.at("v_rmse"));
      s.max_abs = number_from_json(e.at("v_max"));
      s.mean_signed = number_from_json(e.at("v_mean_signed"));
      s.psnr = std::numeric_limits<double>::quiet_NaN();
      r.v_objects.push_back(s);
    }
  r.color_psnr = number_from_json(m.at("color_psnr"));
  r.flip = number_from_json(m.at("flip"));
  r.times = {m.at("total_ms").get<double>(), m.at("camera_pass_ms").get<double>(), m.at("shadow_ms").get<double>()};
  r.run_shadow_ms = m.at("run_shadow_ms").get<std::vector<double>>();
  r.speedup = number_from_json(m.at("speedup"));
  for (auto [prefix, q] : {std::pair{"eq_v", &r.eq_v}, std::pair{"eq_flip", &r.eq_flip}}) {
    const std::string p = prefix;
    q->samples = number_from_json(m.at(p + "_spp"));
    q->bound = bound_from_json(m.at(p + "_bound"));
    q->reference_ms = number_from_json(m.at(p + "_reference_ms"));
    q->speedup = number_from_json(m.at(p + "_speedup"));
  }
  r.run_total_ms = m.at("run_total_ms").get<std::vector<double>>();
  r.stats.rays_traced = m.at("rays_traced").get<uint64_t>();
  r.stats.texels_visited = m.at("texels_visited").get<uint64_t>();
  r.stats.memory_bytes = m.at("memory_bytes").get<uint64_t>();
  r.stats.prepare_count = m.value("prepare_count", uint64_t{0});
  r.view_samples = m.at("view_samples").get<size_t>();
  if (m.contains("phase_order")) {
    r.stats.phases_ms = phases_from_json(m["phase_order"]);
  } else {
    for (const auto& [n, t] : m.at("phases_ms").items()) r.stats.phases_ms.emplace_back(n, t.get<double>());
  }
  if (m.contains("run_phases_ms"))
    for (const json& p : m["run_phases_ms"]) r.run_phases_ms.push_back(phases_from_json(p));
  r.stats.extra = m.value("extra", json::object());
  return r;
}

json ground_truth_json(const GroundTruth& t) {
  return {{"method", "reference"},
          {"spp", t.light_samples},
          {"seed", t.seed},
          {"params", t.params},
          {"total_ms", t.total_ms},
          {"camera_pass_ms", t.camera_pass_ms},
          {"time_basis", time_basis_name(t.time_basis)},
          {"stats", t.stats},
          {"cached", t.from_cache},
          {"cache_key", t.key}};
}

GroundTruth ground_truth_from_json(const json& j) {
  GroundTruth t;
  t.light_samples = j.at("spp").get<int>();
  t.seed = j.at("seed").get<uint64_t>();
  t.params = j.at("params");
  t.total_ms = j.at("total_ms").get<double>();
  t.camera_pass_ms = j.at("camera_pass_ms").get<double>();
  t.stats = j.at("stats");
  t.from_cache = j.at("cached").get<bool>();
  t.time_basis = time_basis_from_name(j.value("time_basis", t.from_cache ? "cached_elsewhere" : "measured"));
  t.key = j.at("cache_key").get<std::string>();
  return t;
}

json reference_ladder_json(const ReferenceLadder& ladder) {
  json rungs = json::array();
  for (const LadderRung& r : ladder.rungs)
    rungs.push_back({{"spp", r.light_samples},
                     {"v_mae", json_number(r.v_mae)},
                     {"flip", json_number(r.flip)},
                     {"shadow_ms", r.shadow_ms},
                     {"total_ms", r.total_ms},
                     {"camera_pass_ms", r.camera_pass_ms},
                     {"run_shadow_ms", r.run_shadow_ms},
                     {"time_basis", time_basis_name(r.time_basis)},
                     {"cached", r.from_cache},
                     {"cache_key", r.key}});
  return {{"method", "reference"},
          {"seed", ladder.seed},
          {"max_spp", ladder.max_samples},
          {"interpolation",
           "log-log: between the first rung at least as good as the method and the rung before "
           "it, log(spp) and log(shadow_ms) linear in log(error)"},
          {"rungs", rungs}};
}

ReferenceLadder reference_ladder_from_json(const json& j) {
  ReferenceLadder ladder;
  ladder.seed = j.at("seed").get<uint64_t>();
  ladder.max_samples = j.at("max_spp").get<int>();
  for (const json& r : j.at("rungs")) {
    LadderRung rung;
    rung.light_samples = r.at("spp").get<int>();
    rung.v_mae = number_from_json(r.at("v_mae"));
    rung.flip = number_from_json(r.at("flip"));
    rung.shadow_ms = r.at("shadow_ms").get<double>();
    rung.total_ms = r.at("total_ms").get<double>();
    rung.camera_pass_ms = r.at("camera_pass_ms").get<double>();
    rung.run_shadow_ms = r.at("run_shadow_ms").get<std::vector<double>>();
    rung.from_cache = r.at("cached").get<bool>();
    rung.time_basis = time_basis_from_name(r.value("time_basis", rung.from_cache ? "cached_elsewhere" : "measured"));
    rung.key = r.at("cache_key").get<std::string>();
    ladder.rungs.push_back(std::move(rung));
  }
  return ladder;
}

namespace {

json numbers_json(const std::vector<double>& v) {
  json out = json::array();
  for (double x : v) out.push_back(json_number(x));
  return out;
}

std::vector<double> numbers_from_json(const json& j) {
  std::vector<double> out;
  for (const json& x : j) out.push_back(number_from_json(x));
  return out;
}

}  // namespace

json frame_sequence_json(const FrameSequence& f) {
  json methods = json::array();
  for (const MethodFrames& m : f.methods) {
    json e = {{"method", m.method}, {"ok", m.ok}};
    if (!m.ok) e["error"] = m.error;
    e["v_mae"] = numbers_json(m.v_mae);
    e["shadow_ms_fresh"] = numbers_json(m.shadow_ms_fresh);
    e["shadow_ms_reuse"] = numbers_json(m.shadow_ms_reuse);
    e["flicker"] = numbers_json(m.flicker);
    e["v_mae_mean"] = json_number(m.v_mae_mean);
    e["temporal_instability"] = json_number(m.temporal_instability);
    e["ms_per_frame_fresh"] = json_number(m.ms_per_frame_fresh);
    e["ms_per_frame_reuse"] = json_number(m.ms_per_frame_reuse);
    methods.push_back(std::move(e));
  }
  json cached = json::array();
  for (bool b : f.truth_cached) cached.push_back(b);
  return {{"range", {f.begin, f.end}},
          {"fps", f.fps},
          {"truth_cached", cached},
          {"temporal_instability",
           "mean over frames t > begin and pixels of |(V_t - V_t-1) - (G_t - G_t-1)|, G the ground truth"},
          {"methods", methods}};
}

FrameSequence frame_sequence_from_json(const json& j) {
  FrameSequence f;
  f.begin = j.at("range").at(0).get<int>();
  f.end = j.at("range").at(1).get<int>();
  f.fps = j.value("fps", 24.0f);
  for (const json& b : j.at("truth_cached")) f.truth_cached.push_back(b.get<bool>());
  for (const json& e : j.at("methods")) {
    MethodFrames m;
    m.method = e.at("method").get<std::string>();
    m.ok = e.at("ok").get<bool>();
    m.error = e.value("error", "");
    m.v_mae = numbers_from_json(e.at("v_mae"));
    m.shadow_ms_fresh = numbers_from_json(e.at("shadow_ms_fresh"));
    m.shadow_ms_reuse = numbers_from_json(e.at("shadow_ms_reuse"));
    m.flicker = numbers_from_json(e.at("flicker"));
    m.v_mae_mean = number_from_json(e.at("v_mae_mean"));
    m.temporal_instability = number_from_json(e.at("temporal_instability"));
    m.ms_per_frame_fresh = number_from_json(e.at("ms_per_frame_fresh"));
    m.ms_per_frame_reuse = number_from_json(e.at("ms_per_frame_reuse"));
    f.methods.push_back(std::move(m));
  }
  return f;
}

json object_groups_json(const std::vector<ObjectGroup>& groups) {
  json out = json::array();
  for (const ObjectGroup& g : groups) out.push_back({{"pattern", g.pattern}, {"objects", g.objects}, {"pixels", g.pixels}});
  return out;
}

json comparison_json(const Comparison& c) {
  json methods = json::array();
  for (const MethodRun& r : c.runs) methods.push_back(method_run_json(r));
  json j = {{"scene", c.scene},
            {"description", c.description},
            {"resolution", {c.width, c.height}},
            {"pixel_samples", c.pixel_samples},
            {"triangles", c.triangles},
            {"lights", c.lights},
            {"spp", c.light_samples},
            {"reference_spp", c.reference_samples},
            {"seed", c.seed},
            {"params", c.params},
            {"speedup_basis", c.speedup_basis},
            {"speedup_basis_ms", c.speedup_basis_ms},
            {"speedup_basis_time", time_basis_name(c.speedup_time_basis)},
            {"machine", c.machine},
            {"started", c.started},
            {"wall_ms", c.wall_ms},
            {"command", c.command},
            {"methods", methods}};
  j["ground_truth"] = c.has_ground_truth ? ground_truth_json(c.truth) : json(nullptr);
  if (!c.object_groups.empty()) j["object_groups"] = object_groups_json(c.object_groups);  // absent without --objects
  // Derived (not read back): the methods above `hard`'s error, when hard ran (issue 34).
  for (const MethodRun& r : c.runs)
    if (r.ok && r.method == "hard" && c.has_ground_truth) j["worse_than_hard"] = worse_than_hard(c);
  j["reference_ladder"] = c.has_ladder ? reference_ladder_json(c.ladder) : json(nullptr);
  if (c.has_frames) j["frames"] = frame_sequence_json(c.frames);  // absent for one frame, as before
  return j;
}

Comparison comparison_from_json(const json& j) {
  Comparison c;
  c.scene = j.at("scene").get<std::string>();
  c.description = j.value("description", "");
  c.width = j.at("resolution").at(0).get<int>();
  c.height = j.at("resolution").at(1).get<int>();
  c.pixel_samples = j.at("pixel_samples").get<int>();
  c.triangles = j.at("triangles").get<size_t>();
  c.lights = j.at("lights").get<size_t>();
  c.light_samples = j.at("spp").get<int>();
  c.reference_samples = j.value("reference_spp", 0);
  c.seed = j.at("seed").get<uint64_t>();
  c.params = j.at("params").get<std::vector<std::string>>();
  c.speedup_basis = j.at("speedup_basis").get<std::string>();
  c.speedup_basis_ms = j.at("speedup_basis_ms").get<double>();
  c.speedup_time_basis = time_basis_from_name(j.value("speedup_basis_time", "measured"));
  c.machine = j.at("machine");
  c.started = j.at("started").get<std::string>();
  c.wall_ms = j.at("wall_ms").get<double>();
  c.command = j.at("command").get<std::string>();
  for (const json& m : j.at("methods")) c.runs.push_back(method_run_from_json(m));
  c.has_ground_truth = !j.at("ground_truth").is_null();
  if (c.has_ground_truth) c.truth = ground_truth_from_json(j["ground_truth"]);
  if (j.contains("object_groups"))
    for (const json& g : j["object_groups"]) {
      ObjectGroup group;
      group.pattern = g.at("pattern").get<std::string>();
      group.objects = g.at("objects").get<size_t>();
      group.pixels = g.at("pixels").get<size_t>();
      c.object_groups.push_back(std::move(group));
    }
  c.has_ladder = !j.at("reference_ladder").is_null();
  if (c.has_ladder) c.ladder = reference_ladder_from_json(j["reference_ladder"]);
  c.has_frames = j.contains("frames") && !j["frames"].is_null();
  if (c.has_frames) c.frames = frame_sequence_from_json(j["frames"]);
  return c;
}

std::string comparison_csv(const Comparison& c) {
  std::vector<std::string> phases;
  for (const MethodRun& r : c.runs)
    for (const auto& [n, t] : r.stats.phases_ms)
      if (std::find(phases.begin(), phases.end(), n) == phases.end()) phases.push_back(n);
  std::ostringstream out;
  out << "method,ok,error,light_samples,v_mae,v_rmse,v_max,v_mean_signed,color_psnr,flip,total_ms,camera_pass_ms,"
         "shadow_ms,speedup,rays_traced,rays_per_view_sample,texels_visited,memory_bytes,eq_v_spp,eq_v_bound,"
         "eq_v_reference_ms,eq_v_speedup,eq_flip_spp,eq_flip_bound,eq_flip_reference_ms,eq_flip_speedup";
  for (const auto& p : phases) out << "," << csv_field("phase_" + p + "_ms");
  // With a sequence (--frame-range), its columns last: the other columns are its first frame's.
  static const char* const kFrameColumns[] = {"frames_v_mae", "temporal_instability", "ms_per_frame_reuse",
                                              "ms_per_frame_fresh"};
  if (c.has_frames)
    for (const char* name : kFrameColumns) out << "," << name;
  // With --objects, each group's mean |dV| and mean signed dV, last.
  for (const ObjectGroup& g : c.object_groups)
    out << "," << csv_field("v_mae[" + g.pattern + "]") << "," << csv_field("v_mean_signed[" + g.pattern + "]");
  out << "\n";
  auto frame_columns = [&](size_t k) {
    if (!c.has_frames) return std::string();
    const MethodFrames* m = k < c.frames.methods.size() ? &c.frames.methods[k] : nullptr;
    if (!m || !m->ok) return std::string(std::size(kFrameColumns), ',');
    return "," + csv_number(m->v_mae_mean) + "," + csv_number(m->temporal_instability) + "," +
           csv_number(m->ms_per_frame_reuse) + "," + csv_number(m->ms_per_frame_fresh);
  };
  auto object_columns = [&](const MethodRun& r) {
    std::string cells;
    for (size_t g = 0; g < c.object_groups.size(); ++g) {
      const bool has = r.ok && g < r.v_objects.size();
      cells += ',';
      if (has) cells += csv_number(r.v_objects[g].mae);
      cells += ',';
      if (has) cells += csv_number(r.v_objects[g].mean_signed);
    }
    return cells;
  };
  for (size_t k = 0; k < c.runs.size(); ++k) {
    const MethodRun& r = c.runs[k];
    out << csv_field(r.method) << "," << (r.ok ? "true" : "false") << "," << csv_field(r.error);
    if (!r.ok) {
      out << std::string(23 + phases.size(), ',') << frame_columns(k) << object_columns(r) << "\n";
      continue;
    }
    out << "," << r.light_samples << "," << csv_number(r.v.mae) << "," << csv_number(r.v.rmse) << ","
        << csv_number(r.v.max_abs) << "," << csv_number(r.v.mean_signed) << "," << csv_number(r.color_psnr) << ","
        << csv_number(r.flip) << "," << csv_number(r.times.total_ms) << "," << csv_number(r.times.camera_pass_ms)
        << "," << csv_number(r.times.shadow_ms) << "," << csv_number(r.speedup) << "," << r.stats.rays_traced << ","
        << csv_number(rays_per_view_sample(r)) << "," << r.stats.texels_visited << "," << r.stats.memory_bytes;
    for (const EqualQuality* q : {&r.eq_v, &r.eq_flip})
      out << "," << csv_number(q->samples) << "," << (q->bound == QualityBound::kNone ? "" : bound_name(q->bound)) << ","
          << csv_number(q->reference_ms) << "," << csv_number(q->speedup);
    for (const auto& p : phases) {
      bool has = std::any_of(r.stats.phases_ms.begin(), r.stats.phases_ms.end(),
                             [&](const auto& e) { return e.first == p; });
      out << "," << (has ? csv_number(r.stats.phase(p)) : std::string());
    }
    out << frame_columns(k) << object_columns(r) << "\n";
  }
  return out.str();
}

std::string image_file_stem(const std::string& label) {
  std::string out;
  for (char ch : label)
    out += (std::isalnum(static_cast<unsigned char>(ch)) || ch == '-' || ch == '_' || ch == '.' || ch == '=') ? ch : '_';
  return out;
}

void write_comparison(const Comparison& c, const fs::path& dir, const ReportOptions& options) {
  fs::create_directories(dir);
  if (options.write_images) {
    fs::create_directories(dir / "images");
    if (c.has_ground_truth && !c.truth.color.empty())
      write_image((dir / "images" / "ground-truth.exr").string(), c.truth.color, {{"V", &c.truth.visibility}});
    for (const MethodRun& r : c.runs)
      if (r.ok && !r.color.empty())
        write_image((dir / "images" / (image_file_stem(r.method) + ".exr")).string(), r.color, {{"V", &r.visibility}});
  }
  write_text_file_atomic(dir / "results.json", comparison_json(c).dump(2) + "\n");
  write_text_file_atomic(dir / "results.csv", comparison_csv(c));
  if (c.has_ground_truth) {
    write_text_file_atomic(dir / "error-time.svg", error_time_svg(c, "v_mae"));
    write_text_file_atomic(dir / "flip-time.svg", error_time_svg(c, "flip"));
  }
  if (c.has_frames) {
    write_text_file_atomic(dir / "frames-error.svg", frames_svg(c, "v_mae"));
    write_text_file_atomic(dir / "frames-time.svg", frames_svg(c, "shadow_ms"));
  }
  write_text_file_atomic(dir / "index.html", comparison_html(c, options));
}

}  // namespace penumbra
