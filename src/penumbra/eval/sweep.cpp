#include "penumbra/eval/sweep.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <sstream>

#include <fmt/format.h>

#include "penumbra/core/file_util.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/eval/report_util.h"
#include "penumbra/eval/svg_plot.h"

namespace penumbra {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

bool parse_double(const std::string& s, double* out) {
  const char* b = s.c_str();
  char* e = nullptr;
  errno = 0;
  double v = std::strtod(b, &e);
  if (s.empty() || e != b + s.size() || errno == ERANGE || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

std::string safe_name(const std::string& s) {
  std::string out;
  for (char c : s) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_' || c == '=') ? c : '_';
  return out;
}

const std::vector<std::string>& base_columns() {
  static const std::vector<std::string> cols = {
      "light_samples", "v_mae",          "v_rmse",    "v_max",   "v_mean_signed", "color_psnr",
      "flip",          "total_ms",       "camera_pass_ms", "shadow_ms", "speedup", "rays_traced",
      "rays_per_view_sample", "texels_visited", "memory_bytes",  "ground_truth_ms"};
  return cols;
}

}  // namespace

Sweep sweep_header(const RunSetup& base, const SweepOptions& options) {
  if (options.key.empty()) throw Error("sweep: no parameter to vary (--param key=v1,v2,...)");
  if (options.values.empty()) throw Error("sweep: --param {}: no values", options.key);
  Sweep s;
  s.scene = base.scene_path.string();
  s.key = options.key;
  s.values = options.values;
  s.methods = options.methods;
  s.has_ground_truth = options.ground_truth;
  s.started = local_time_iso();
  s.machine = machine_json();
  for (const auto& v : options.values) {
    double x;
    s.numeric = s.numeric && parse_double(v, &x);
  }
  return s;
}

std::vector<RunSetup> sweep_setups(const RunSetup& base, const SweepOptions& options) {
  std::vector<RunSetup> setups;
  for (const auto& v : options.values) {
    RunSetup setup = base;
    try {
      setup.apply(options.key, v);
    } catch (const Interrupted&) {
      throw;  // Ctrl-C ends the run, whatever this step would do with an error
    } catch (const Error& e) {
      throw Error("sweep: {}", e.what());
    }
    setup.check_plain_params(options.methods);
    setups.push_back(std::move(setup));
  }
  return setups;
}

CompareOptions sweep_compare_options(const SweepOptions& options) {
  CompareOptions co;
  co.methods = options.methods;
  co.ground_truth = options.ground_truth;
  co.cache_dir = options.cache_dir;
  co.runs = options.runs;
  co.warmup_runs = options.warmup_runs;
  co.keep_images = !options.pages_dir.empty();
  co.equal_quality = false;  // a sweep's values would each render a reference ladder
  return co;
}

void add_sweep_value(Sweep& s, size_t i, Comparison c, const SweepOptions& options) {
  const std::string& value = options.values[i];
  if (!options.pages_dir.empty()) {
    c.command = fmt::format("(sweep {}={})", options.key, value);
    write_comparison(c, options.pages_dir / safe_name(options.key + "=" + value), ReportOptions{0, false});
  }
  s.comparisons.push_back(comparison_json(c));
  double x = static_cast<double>(i);
  if (s.numeric) parse_double(value, &x);
  for (MethodRun& r : c.runs) {
    SweepRow row;
    row.value = value;
    row.x = x;
    r.color = Image();
    r.visibility = Image();
    row.run = std::move(r);
    if (c.has_ground_truth) row.ground_truth_ms = c.truth.total_ms;
    s.rows.push_back(std::move(row));
  }
}

Sweep run_sweep(const RunSetup& base, const SweepOptions& options) {
  Timer wall;
  Sweep s = sweep_header(base, options);
  // Every value's setup first: a bad value fails before any render.
  const std::vector<RunSetup> setups = sweep_setups(base, options);
  CompareOptions co = sweep_compare_options(options);
  uint64_t total = 0;
  for (const auto& setup : setups) total += comparison_progress_units(setup, co);
  Progress bar(fmt::format("sweep {}", options.key), total, options.progress);
  co.progress_bar = &bar;
  for (size_t i = 0; i < setups.size(); ++i) add_sweep_value(s, i, run_comparison(setups[i], co), options);
  bar.finish();
  s.wall_ms = wall.elapsed_ms();
  return s;
}

std::vector<std::pair<std::string, double>> flatten_numbers(const json& j, const std::string& prefix) {
  std::vector<std::pair<std::string, double>> out;
  std::function<void(const json&, const std::string&)> walk = [&](const json& v, const std::string& key) {
    if (v.is_number()) {
      out.emplace_back(key, v.get<double>());
    } else if (v.is_object()) {
      for (auto it = v.begin(); it != v.end(); ++it) walk(it.value(), key + "." + it.key());
    } else if (v.is_array() && !v.empty()) {
      walk(v.back(), key);  // a curve's final value
    }
  };
  if (j.is_object())
    for (auto it = j.begin(); it != j.end(); ++it) walk(it.value(), prefix + "." + it.key());
  return out;
}

double sweep_value(const SweepRow& row, const std::string& column) {
  const MethodRun& r = row.run;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!r.ok) return nan;
  if (column == "light_samples") return r.light_samples;
  if (column == "v_mae") return r.v.mae;
  if (column == "v_rmse") return r.v.rmse;
  if (column == "v_max") return r.v.max_abs;
  if (column == "v_mean_signed") return r.v.mean_signed;
  if (column == "color_psnr") return r.color_psnr;
  if (column == "flip") return r.flip;
  if (column == "total_ms") return r.times.total_ms;
  if (column == "camera_pass_ms") return r.times.camera_pass_ms;
  if (column == "shadow_ms") return r.times.shadow_ms;
  if (column == "speedup") return r.speedup;
  if (column == "rays_traced") return static_cast<double>(r.stats.rays_traced);
  if (column == "rays_per_view_sample") return rays_per_view_sample(r);
  if (column == "texels_visited") return static_cast<double>(r.stats.texels_visited);
  if (column == "memory_bytes") return static_cast<double>(r.stats.memory_bytes);
  if (column == "ground_truth_ms") return row.ground_truth_ms;
  if (column.rfind("phase_", 0) == 0 && column.size() > 9 && column.substr(column.size() - 3) == "_ms") {
    std::string name = column.substr(6, column.size() - 9);
    for (const auto& [n, t] : r.stats.phases_ms)
      if (n == name) return t;
    return nan;
  }
  if (column.rfind("extra.", 0) == 0) {
    for (const auto& [k, v] : flatten_numbers(r.stats.extra, "extra"))
      if (k == column) return v;
    return nan;
  }
  throw Error("unknown sweep column '{}'", column);
}

void check_sweep_column(const std::string& c) {
  const auto& cols = base_columns();
  if (std::find(cols.begin(), cols.end(), c) != cols.end()) return;
  // phase_<name>_ms and extra.<key> exist only once a method reported them.
  if ((c.rfind("phase_", 0) == 0 && c.size() > 9 && c.substr(c.size() - 3) == "_ms") ||
      (c.rfind("extra.", 0) == 0 && c.size() > 6))
    return;
  std::string list;
  for (const auto& k : cols) list += (list.empty() ? "" : ", ") + k;
  throw Error("--plot {}: unknown column (columns: {}, phase_<name>_ms, extra.<key>)", c, list);
}

std::vector<std::string> sweep_columns(const Sweep& s) {
  std::vector<std::string> cols = base_columns();
  auto add = [&](const std::string& c) {
    if (std::find(cols.begin(), cols.end(), c) == cols.end()) cols.push_back(c);
  };
  for (const SweepRow& row : s.rows)
    for (const auto& [n, t] : row.run.stats.phases_ms) add("phase_" + n + "_ms");
  for (const SweepRow& row : s.rows)
    for (const auto& [k, v] : flatten_numbers(row.run.stats.extra, "extra")) add(k);
  return cols;
}

std::string sweep_csv(const Sweep& s) {
  std::vector<std::string> cols = sweep_columns(s);
  std::ostringstream out;
  out << "key,value,x,method,ok,error";
  for (const auto& c : cols) out << "," << csv_field(c);
  out << "\n";
  for (const SweepRow& row : s.rows) {
    out << csv_field(s.key) << "," << csv_field(row.value) << "," << csv_number(row.x) << ","
        << csv_field(row.run.method) << "," << (row.run.ok ? "true" : "false") << "," << csv_field(row.run.error);
    for (const auto& c : cols) {
      double v = sweep_value(row, c);
      // Integer counters without a decimal point.
      bool integer = c == "rays_traced" || c == "texels_visited" || c == "memory_bytes" || c == "light_samples";
      out << "," << (integer && !std::isnan(v) ? fmt::format("{}", static_cast<uint64_t>(v)) : csv_number(v));
    }
    out << "\n";
  }
  return out.str();
}

json sweep_json(const Sweep& s) {
  json rows = json::array();
  std::vector<std::string> cols = sweep_columns(s);
  for (const SweepRow& row : s.rows) {
    json r = {{"value", row.value}, {"x", row.x}, {"method", row.run.method}, {"ok", row.run.ok}};
    if (!row.run.ok) r["error"] = row.run.error;
    for (const auto& c : cols) r[c] = json_number(sweep_value(row, c));
    if (row.run.ok) r["params"] = row.run.params;
    rows.push_back(r);
  }
  return {{"scene", s.scene},   {"key", s.key},         {"values", s.values},   {"methods", s.methods},
          {"numeric", s.numeric}, {"ground_truth", s.has_ground_truth}, {"machine", s.machine},
          {"started", s.started}, {"wall_ms", s.wall_ms}, {"command", s.command}, {"rows", rows},
          {"comparisons", s.comparisons}};
}

namespace {

std::string column_label(const std::string& c) {
  if (c == "v_mae") return "mean |ΔV| (against the ground truth)";
  if (c == "v_rmse") return "RMSE of V";
  if (c == "v_max") return "max |ΔV|";
  if (c == "v_mean_signed") return "mean ΔV (bias)";
  if (c == "color_psnr") return "PSNR of the colour image (dB)";
  if (c == "flip") return "mean FLIP";
  if (c == "shadow_ms") return "shadow time (ms)";
  if (c == "total_ms") return "total render time (ms)";
  if (c == "camera_pass_ms") return "camera pass (ms)";
  if (c == "speedup") return "speed-up vs reference";
  if (c == "rays_traced") return "rays traced";
  if (c == "rays_per_view_sample") return "rays traced per view sample";
  if (c == "memory_bytes") return "memory (bytes)";
  return c;
}

}  // namespace

std::string sweep_plot(const Sweep& s, const std::string& column, const SweepPlotOptions& o) {
  Plot p;
  p.x_label = s.key;
  p.y_label = column_label(column);
  std::string what = column == "v_mae" ? "mean |ΔV|" : column_label(column);
  p.title = fmt::format("{}: {} against {}", fs::path(s.scene).stem().string(), what, s.key);
  if (!s.numeric) p.x_categories = s.values;
  double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
  for (const std::string& m : s.methods) {
    PlotSeries ser;
    ser.name = m;
    for (const SweepRow& row : s.rows) {
      if (row.run.method != m) continue;
      ser.x.push_back(row.x);
      double y = sweep_value(row, column);
      ser.y.push_back(y);
      if (std::isfinite(y) && y > 0) ymin = std::min(ymin, y), ymax = std::max(ymax, y);
      if (row.x > 0) xmin = std::min(xmin, row.x), xmax = std::max(xmax, row.x);
    }
    p.series.push_back(std::move(ser));
  }
  bool all_x_positive = true;
  for (const SweepRow& row : s.rows) all_x_positive = all_x_positive && row.x > 0;
  switch (o.x_scale) {
    case AxisScale::kLog: p.log_x = s.numeric; break;
    case AxisScale::kLinear: p.log_x = false; break;
    case AxisScale::kAuto: p.log_x = s.numeric && all_x_positive && xmax >= 16 * xmin; break;
  }
  switch (o.y_scale) {
    case AxisScale::kLog: p.log_y = true; break;
    case AxisScale::kLinear: p.log_y = false; break;
    case AxisScale::kAuto: p.log_y = std::isfinite(ymin) && ymax > 100 * ymin; break;
  }
  return plot_svg(p);
}

std::vector<fs::path> write_sweep(const Sweep& s, const fs::path& dir, const SweepPlotOptions& o) {
  fs::create_directories(dir);
  write_text_file_atomic(dir / "sweep.csv", sweep_csv(s));
  write_text_file_atomic(dir / "sweep.json", sweep_json(s).dump(2) + "\n");
  std::vector<std::pair<std::string, std::string>> plots;  // file stem, column
  if (s.has_ground_truth) plots.emplace_back("error", "v_mae");
  plots.emplace_back("time", "shadow_ms");
  bool rays = std::any_of(s.rows.begin(), s.rows.end(), [](const SweepRow& r) { return r.run.ok && r.run.stats.rays_traced > 0; });
  if (rays) plots.emplace_back("rays", "rays_traced");
  for (const auto& c : o.extra_plots) {
    check_sweep_column(c);
    plots.emplace_back(safe_name(c), c);
  }
  // Every number a method reports at the top level of its stats' "extra" (e.g. a hit
  // rate) gets a plot of its own without being asked for; nested ones when asked.
  for (const auto& c : sweep_columns(s))
    if (c.rfind("extra.", 0) == 0 && c.find('.', 6) == std::string::npos && std::none_of(plots.begin(), plots.end(), [&](const auto& p) { return p.second == c; }))
      plots.emplace_back(safe_name(c), c);
  std::vector<fs::path> written;
  for (const auto& [stem, column] : plots) {
    fs::path f = dir / (stem + ".svg");
    write_text_file_atomic(f, sweep_plot(s, column, o));
    written.push_back(f);
  }
  return written;
}

}  // namespace penumbra
