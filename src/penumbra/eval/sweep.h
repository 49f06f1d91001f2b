// A sweep: one settings key (run_setup.h: light.size, spp, resolution, generator.leaves,
// <method>.<param>, ...) varied over a list of values, a comparison per value, and the
// results gathered into one table (sweep.csv / sweep.json) and plots (SVG) of error, time
// and any other column against the value (docs/compare.md, "penumbra sweep").
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/eval/comparison.h"

namespace penumbra {

enum class AxisScale { kAuto, kLinear, kLog };

struct SweepOptions {
  std::string key;                  // the settings key varied
  std::vector<std::string> values;  // its values, in order
  std::vector<std::string> methods;
  bool ground_truth = true;         // false: timings only (no reference renders)
  std::filesystem::path cache_dir;  // the reference cache
  int runs = 1;
  int warmup_runs = 0;
  bool progress = false;
  // Non-empty: also write a comparison page per value to pages_dir/<key>=<value>/.
  std::filesystem::path pages_dir;
};

struct SweepRow {
  std::string value;
  double x = 0;     // the value as a number (its index on a categorical axis)
  MethodRun run;    // without images
  double ground_truth_ms = std::numeric_limits<double>::quiet_NaN();
};

struct Sweep {
  std::string scene, key;
  std::vector<std::string> values, methods;
  bool numeric = true;          // every value is a number (else the x axis is categorical)
  bool has_ground_truth = false;
  std::vector<SweepRow> rows;   // value-major: for each value, each method
  std::vector<nlohmann::json> comparisons;  // comparison_json() per value (settings, ground truth, machine)
  nlohmann::json machine;
  std::string started, command;
  double wall_ms = 0;
};

Sweep run_sweep(const RunSetup& base, const SweepOptions& options);

// --- A sweep in steps (run_sweep; penumbra.distributed runs each value's comparison as jobs):
// the sweep without rows; every value's setup (a bad value throws before anything renders);
// the comparison options of each value; then each value's comparison added in order.
Sweep sweep_header(const RunSetup& base, const SweepOptions& options);
std::vector<RunSetup> sweep_setups(const RunSetup& base, const SweepOptions& options);
CompareOptions sweep_compare_options(const SweepOptions& options);
void add_sweep_value(Sweep& s, size_t value_index, Comparison c, const SweepOptions& options);

// The numbers in a method's MethodStats::extra as columns: "<prefix>.<key>", nested objects
// as "<prefix>.<key>.<key>", an array as its last element (a curve's final value, e.g.
// lam's depth_complexity per light sample); strings and booleans are left out.
std::vector<std::pair<std::string, double>> flatten_numbers(const nlohmann::json& j, const std::string& prefix);

// The numeric columns a row offers (for --plot): v_mae, v_rmse, v_max, v_mean_signed,
// color_psnr, flip, total_ms, camera_pass_ms, shadow_ms, speedup, rays_traced,
// rays_per_view_sample, texels_visited, memory_bytes, ground_truth_ms, phase_<name>_ms
// and extra.<key>.
double sweep_value(const SweepRow& row, const std::string& column);
std::vector<std::string> sweep_columns(const Sweep& s);
// Throws unless `column` can name a sweep column (before a sweep runs: --plot checks).
void check_sweep_column(const std::string& column);

std::string sweep_csv(const Sweep& s);
nlohmann::json sweep_json(const Sweep& s);

struct SweepPlotOptions {
  AxisScale x_scale = AxisScale::kAuto;  // auto: log when all values > 0 spanning >= 16x
  AxisScale y_scale = AxisScale::kAuto;  // auto: log when the values span more than 100x
  std::vector<std::string> extra_plots;  // more columns to plot (sweep_columns)
};
// The SVG plot of `column` against the swept value, one series per method.
std::string sweep_plot(const Sweep& s, const std::string& column, const SweepPlotOptions& options = {});

// Writes DIR/sweep.csv, DIR/sweep.json and the plots: error.svg (v_mae, with a ground
// truth), time.svg (shadow_ms), rays.svg (when any method traced rays), one <column>.svg
// per extra plot asked for and one extra.<key>.svg per number a method reported at the
// top level of its MethodStats::extra (nested ones, extra.<key>.<key>, when asked for).
// Returns the plot files written.
std::vector<std::filesystem::path> write_sweep(const Sweep& s, const std::filesystem::path& dir,
                                               const SweepPlotOptions& options = {});

}  // namespace penumbra
