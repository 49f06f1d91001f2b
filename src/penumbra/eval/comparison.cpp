#include "penumbra/eval/comparison.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <ctime>
#include <fstream>
#include <set>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <tbb/global_control.h>

#include "penumbra/core/file_util.h"
#include "penumbra/core/interrupt.h"
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
  std::string cpu = "unknown";
  std::ifstream f("/proc/cpuinfo");
  for (std::string line; std::getline(f, line);) {
    if (line.rfind("model name", 0) == 0) {
      auto colon = line.find(':');
      if (colon != std::string::npos) cpu = line.substr(line.find_first_not_of(" \t", colon + 1));
      break;
    }
  }
#ifdef NDEBUG
  const char* build = "Release (NDEBUG)";
#else
  const char* build = "Debug (asserts on)";
#endif
  return {{"cpu", cpu},
          {"logical_cores", std::thread::hardware_concurrency()},
          {"threads", tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)},
          {"compiler", fmt::format("g++ {}", __VERSION__)},
          {"build", build}};
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

double shadow_time_ms(const RenderResult& r) {
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

Comparison run_comparison(const RunSetup& setup, const CompareOptions& options) {
  Timer wall;
  if (options.methods.empty()) throw Error("compare: no methods to run");
  setup.check_plain_params(options.methods);
  Comparison c;
  c.started = local_time_iso();
  c.machine = machine_json();
  c.scene = setup.scene_path.string();
  c.description = setup.scene_doc.value("description", "");
  c.light_samples = setup.light_samples;
  c.reference_samples = setup.reference_samples;
  c.seed = setup.seed;
  c.params = setup.method_params;

  const Scene scene = setup.load();
  c.width = scene.camera.width;
  c.height = scene.camera.height;
  c.pixel_samples = scene.camera.samples_per_pixel;
  c.triangles = scene.triangle_count();
  c.lights = scene.lights.size();

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
  Image truth_display;
  if (c.has_ground_truth) truth_display = display_srgb(c.truth.color);

  // Every method's renders, in the order of the schedule: all runs of one method in a row,
  // or (interleave) run i of every method before run i+1 of any.
  struct Pending {
    MethodRun run;
    RenderSettings settings;
    std::vector<RenderResult> results;
    bool failed = false;
  };
  std::vector<Pending> pending(options.methods.size());
  for (size_t k = 0; k < options.methods.size(); ++k) {
    Pending& p = pending[k];
    const std::string& name = options.methods[k];
    p.run.method = name;
    const MethodSpec spec = parse_method_spec(name);
    const MethodInfo& info = MethodRegistry::get(spec.name);
    p.run.light_samples = info.samples_light ? setup.light_samples : 0;
    p.settings.method = spec.name;
    p.settings.params = setup.overrides_for(spec);
    p.settings.light_samples = setup.light_samples;
    p.settings.seed = setup.seed;
    p.settings.progress_bar = bar;
  }
  std::vector<std::pair<size_t, int>> schedule;  // (method, render)
  if (options.interleave) {
    for (int i = 0; i < runs; ++i)
      for (size_t k = 0; k < pending.size(); ++k) schedule.emplace_back(k, i);
  } else {
    for (size_t k = 0; k < pending.size(); ++k)
      for (int i = 0; i < runs; ++i) schedule.emplace_back(k, i);
  }
  for (auto [k, i] : schedule) {
    Pending& p = pending[k];
    budget.begin(fmt::format("compare: {}", p.run.method), per_render);
    if (p.failed) {  // a run that will not happen counts as done
      budget.end();
      continue;
    }
    try {
      p.results.push_back(render_scene(scene, p.settings));
    } catch (const Interrupted&) {
      throw;  // Ctrl-C ends the run, whatever this step would do with an error
    } catch (const std::exception& e) {
      p.failed = true;
      p.run.error = e.what();
      p.results.clear();
    }
    budget.end();
    // Only the first run's images are kept (they are the same every run).
    if (!p.failed && i > 0) {
      p.results.back().color = Image();
      p.results.back().visibility = Image();
    }
  }

  for (Pending& p : pending) {
    MethodRun& run = p.run;
    if (p.failed) {
      run.ok = false;
      run.v.mae = run.v.rmse = run.v.max_abs = run.v.mean_signed = run.v.psnr =
          std::numeric_limits<double>::quiet_NaN();
      c.runs.push_back(std::move(run));
      continue;
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
    run.params = m.resolved_params;
    run.view_samples = m.view_sample_count;
    RenderResult& first = results.front();
    if (c.has_ground_truth) {
      run.v = compare_images(first.visibility, c.truth.visibility);
      run.color_psnr = compare_images(display_srgb(first.color), truth_display).psnr;
      run.flip = flip(first.color, c.truth.color).mean;
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
    c.runs.push_back(std::move(run));
  }

  // Equal quality: the reference ladder, rendered as far as the best method needs.
  if (c.has_ground_truth && options.equal_quality) {
    double best_v = std::numeric_limits<double>::quiet_NaN(), best_flip = best_v;
    for (const MethodRun& r : c.runs) {
      if (!r.ok) continue;
      if (std::isfinite(r.v.mae) && !(r.v.mae >= best_v)) best_v = r.v.mae;
      if (std::isfinite(r.flip) && !(r.flip >= best_flip)) best_flip = r.flip;
    }
    if (std::isfinite(best_v) || std::isfinite(best_flip)) {
      c.ladder = render_reference_ladder(setup, scene, c.truth, best_v, best_flip, options.cache_dir, options.runs,
                                         options.warmup_runs, bar);
      c.has_ladder = true;
      const std::vector<LadderPoint> v_points = ladder_points(c.ladder, "v_mae");
      const std::vector<LadderPoint> flip_points = ladder_points(c.ladder, "flip");
      for (MethodRun& r : c.runs) {
        if (!r.ok) continue;
        r.eq_v = equal_quality_search(v_points, r.v.mae, r.times.shadow_ms);
        r.eq_flip = equal_quality_search(flip_points, r.flip, r.times.shadow_ms);
      }
    }
  }
  own.finish();

  // Speed ratios: against the reference method at the same spp when it was compared, else
  // against the ground truth's own render.
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
  }
  for (MethodRun& r : c.runs)
    if (r.ok && !c.speedup_basis.empty() && r.times.shadow_ms > 0) r.speedup = c.speedup_basis_ms / r.times.shadow_ms;
  c.wall_ms = wall.elapsed_ms();
  return c;
}

double rays_per_view_sample(const MethodRun& r) {
  return r.view_samples ? static_cast<double>(r.stats.rays_traced) / r.view_samples
                        : std::numeric_limits<double>::quiet_NaN();
}

json comparison_json(const Comparison& c) {
  json methods = json::array();
  for (const MethodRun& r : c.runs) {
    json m = {{"method", r.method}, {"ok", r.ok}};
    if (!r.ok) {
      m["error"] = r.error;
    } else {
      m["params"] = r.params;
      m["light_samples"] = r.light_samples;
      m["v_mae"] = json_number(r.v.mae);
      m["v_rmse"] = json_number(r.v.rmse);
      m["v_max"] = json_number(r.v.max_abs);
      m["v_mean_signed"] = json_number(r.v.mean_signed);
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
      m["view_samples"] = r.view_samples;
      json phases = json::object();
      for (const auto& [n, t] : r.stats.phases_ms) phases[n] = t;
      m["phases_ms"] = phases;
      m["extra"] = r.stats.extra;
    }
    methods.push_back(m);
  }
  json j = {{"scene", c.scene},
            {"description", c.description},
            {"resolution", {c.width, c.height}},
            {"pixel_samples", c.pixel_samples},
            {"triangles", c.triangles},
            {"lights", c.lights},
            {"spp", c.light_samples},
            {"seed", c.seed},
            {"params", c.params},
            {"speedup_basis", c.speedup_basis},
            {"speedup_basis_ms", c.speedup_basis_ms},
            {"machine", c.machine},
            {"started", c.started},
            {"wall_ms", c.wall_ms},
            {"command", c.command},
            {"methods", methods}};
  if (c.has_ground_truth) {
    j["ground_truth"] = {{"method", "reference"},
                         {"spp", c.truth.light_samples},
                         {"seed", c.truth.seed},
                         {"params", c.truth.params},
                         {"total_ms", c.truth.total_ms},
                         {"camera_pass_ms", c.truth.camera_pass_ms},
                         {"stats", c.truth.stats},
                         {"cached", c.truth.from_cache},
                         {"cache_key", c.truth.key}};
  } else {
    j["ground_truth"] = nullptr;
  }
  if (c.has_ladder) {
    json rungs = json::array();
    for (const LadderRung& r : c.ladder.rungs)
      rungs.push_back({{"spp", r.light_samples},
                       {"v_mae", json_number(r.v_mae)},
                       {"flip", json_number(r.flip)},
                       {"shadow_ms", r.shadow_ms},
                       {"total_ms", r.total_ms},
                       {"camera_pass_ms", r.camera_pass_ms},
                       {"run_shadow_ms", r.run_shadow_ms},
                       {"cached", r.from_cache},
                       {"cache_key", r.key}});
    j["reference_ladder"] = {{"method", "reference"},
                             {"seed", c.ladder.seed},
                             {"max_spp", c.ladder.max_samples},
                             {"interpolation",
                              "log-log: between the first rung at least as good as the method and the rung before "
                              "it, log(spp) and log(shadow_ms) linear in log(error)"},
                             {"rungs", rungs}};
  } else {
    j["reference_ladder"] = nullptr;
  }
  return j;
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
  out << "\n";
  for (const MethodRun& r : c.runs) {
    out << csv_field(r.method) << "," << (r.ok ? "true" : "false") << "," << csv_field(r.error);
    if (!r.ok) {
      out << std::string(23 + phases.size(), ',') << "\n";
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
    out << "\n";
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
  write_text_file_atomic(dir / "index.html", comparison_html(c, options));
}

}  // namespace penumbra
