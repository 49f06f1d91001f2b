// penumbra sweep SCENE --param key=v1,v2,... (--method M | --methods a,b) [--set key=value]... -o DIR
// One setting varied over a list of values: a comparison per value, sweep.csv, sweep.json
// and SVG plots of error and time against the value (docs/compare.md).
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <fmt/format.h>

#include "app/command.h"
#include "penumbra/gpu/device.h"
#include "app/common.h"
#include "penumbra/core/parallel.h"
#include "penumbra/eval/sweep.h"
#include "penumbra/scene/json_reader.h"

namespace penumbra::app {
namespace {

struct SweepCliOptions {
  std::string scene;
  std::string param;
  std::vector<std::string> method, methods;
  int spp = 256;
  int reference_spp = 1024;
  std::string resolution;
  uint64_t seed = 0;
  std::vector<std::string> sets;
  std::string output;
  bool no_reference = false;
  int runs = 1, warmup = 0;
  std::vector<std::string> plots;
  std::string x_scale = "auto", y_scale = "auto";
  bool pages = false;
  std::string cache_dir;
  bool no_cache = false;
  int threads = 0;
  std::string device = "cpu";  // --device: every method's unless its --methods entry names one
  bool quiet = false;
  std::string dask;             // a Dask scheduler's address: the jobs run there
  std::string meshes = "ship";  // with --dask: ship the mesh files, or read them from a shared path
};

AxisScale axis(const std::string& s) {
  return s == "log" ? AxisScale::kLog : s == "linear" ? AxisScale::kLinear : AxisScale::kAuto;
}

int run_sweep_cli(const SweepCliOptions& o) {
  ThreadLimit limit(o.threads);
  auto eq = o.param.find('=');
  if (eq == std::string::npos || eq == 0) throw Error("--param {}: expected key=v1,v2,...", o.param);
  SweepOptions so;
  so.key = o.param.substr(0, eq);
  so.values = split_list(o.param.substr(eq + 1));
  if (so.values.empty()) throw Error("--param {}: no values", o.param);
  std::vector<std::string> names = o.method;
  names.insert(names.end(), o.methods.begin(), o.methods.end());
  if (names.empty()) throw Error("sweep: name the method(s) to sweep: --method M or --methods a,b,...");
  so.methods = expand_method_list(names);
  for (const auto& c : o.plots) check_sweep_column(c);

  RunSetup setup = RunSetup::from_file(o.scene);
  setup.light_samples = o.spp;
  setup.reference_samples = o.reference_spp;
  setup.seed = o.seed;
  setup.device = gpu::DeviceChoice::parse(o.device).to_string();
  if (!o.resolution.empty()) setup.apply("resolution", o.resolution);
  for (const std::string& kv : o.sets) setup.apply(kv);

  std::string out = o.output.empty()
                        ? fmt::format("sweep-{}-{}", std::filesystem::path(o.scene).stem().string(), so.key)
                        : o.output;
  so.ground_truth = !o.no_reference;
  so.cache_dir = o.no_cache ? std::filesystem::path() : o.cache_dir.empty() ? default_cache_dir() : std::filesystem::path(o.cache_dir);
  so.runs = o.runs;
  so.warmup_runs = o.warmup;
  so.progress = !o.quiet;
  if (o.pages) so.pages_dir = std::filesystem::path(out) / "pages";

  make_output_folder(out);  // before any render: a bad -o fails at once
  SweepPlotOptions po;
  po.x_scale = axis(o.x_scale);
  po.y_scale = axis(o.y_scale);
  po.extra_plots = o.plots;
  Sweep s;
  std::vector<std::filesystem::path> plots;
  if (!o.dask.empty()) {
    // Every value's comparison as jobs on the cluster, all at once (docs/distributed.md);
    // penumbra.distributed writes the same files, read back here for the summary.
    if (o.pages) throw Error("--pages: not available with --dask (the pages' images stay on the workers)");
    sweep_setups(setup, so);  // a bad value fails here, before the cluster is asked
    const nlohmann::json request = {{"command", "sweep"},
                                    {"setup", run_setup_json(setup)},
                                    {"key", so.key},
                                    {"values", so.values},
                                    {"methods", so.methods},
                                    {"ground_truth", so.ground_truth},
                                    {"runs", so.runs},
                                    {"warmup_runs", so.warmup_runs},
                                    {"cache_dir", so.cache_dir.string()},
                                    {"meshes", o.meshes},
                                    {"output", std::filesystem::absolute(out).string()},
                                    {"plots", o.plots},
                                    {"x_scale", o.x_scale},
                                    {"y_scale", o.y_scale},
                                    {"command_line", command_line()}};
    if (const int code = run_on_dask(request, o.dask); code != 0) return code;
    const nlohmann::json j = read_json_file(std::filesystem::path(out) / "sweep.json");
    s = sweep_header(setup, so);
    s.wall_ms = j.at("wall_ms").get<double>();
    for (size_t i = 0; i < j.at("comparisons").size(); ++i)
      add_sweep_value(s, i, comparison_from_json(j["comparisons"][i]), so);
    for (const auto& entry : std::filesystem::directory_iterator(out))
      if (entry.path().extension() == ".svg") plots.push_back(entry.path());
  } else {
    s = run_sweep(setup, so);
    s.command = command_line();
    plots = write_sweep(s, out, po);
  }
  if (!o.quiet) {
    std::printf("%-12s %-20s %11s %11s %14s\n", so.key.c_str(), "method", "mean|dV|", "shadow ms", "rays");
    for (const SweepRow& r : s.rows) {
      if (!r.run.ok) {
        std::printf("%-12s %-20s failed: %s\n", r.value.c_str(), r.run.method.c_str(), r.run.error.c_str());
        continue;
      }
      std::string mae = std::isnan(r.run.v.mae) ? "-" : fmt::format("{:.5f}", r.run.v.mae);
      std::printf("%-12s %-20s %11s %11.2f %14llu\n", r.value.c_str(), r.run.method.c_str(), mae.c_str(),
                  r.run.times.shadow_ms, static_cast<unsigned long long>(r.run.stats.rays_traced));
    }
    std::string files;
    for (const auto& p : plots) files += " " + p.filename().string();
    std::fprintf(stderr, "%s: sweep of %s over %zu values, %.1f s -> %s/sweep.csv,%s\n", o.scene.c_str(),
                 so.key.c_str(), so.values.size(), s.wall_ms / 1000, out.c_str(), files.c_str());
  }
  return 0;
}

const CommandRegistration sweep_command("sweep", 60, [](CLI::App& app) {
  auto o = std::make_shared<SweepCliOptions>();
  CLI::App* cmd = app.add_subcommand("sweep", "vary one setting over a list of values: CSV and SVG plots of error and time");
  cmd->add_option("scene", o->scene, "scene file (JSON)")->required();
  cmd->add_option("--param", o->param,
                  "the setting to vary and its values, key=v1,v2,... (keys: spp, resolution, light.size_scale, "
                  "light.size, light.radius, generator.<param>, <method>.<param>, <param>, ...)")
      ->required();
  cmd->add_option("-m,--method", o->method, "method to sweep (repeatable)");
  cmd->add_option("--methods", o->methods, "methods to sweep, comma-separated, or 'all'")->delimiter(',');
  cmd->add_option("--spp", o->spp, "light samples of every method that samples the light")
      ->capture_default_str()->check(CLI::Range(1, 1 << 20));
  cmd->add_option("--reference-spp", o->reference_spp, "light samples of the ground truth")
      ->capture_default_str()->check(CLI::Range(1, 1 << 20));
  cmd->add_option("--resolution", o->resolution, "image size N or WxH (overrides the scene's camera)");
  cmd->add_option("--seed", o->seed, "random seed")->capture_default_str();
  cmd->add_option("--set", o->sets, "a fixed setting key=value for every value (repeatable; keys as --param)");
  cmd->add_option("-o,--output", o->output, "output folder (default sweep-<scene>-<key>)");
  cmd->add_flag("--no-reference", o->no_reference, "timings only: no ground truth, no error columns");
  cmd->add_option("--runs", o->runs, "timed renders per method and value (the median is reported)")
      ->capture_default_str()->check(CLI::Range(1, 100));
  cmd->add_option("--warmup", o->warmup, "untimed renders before the timed ones")
      ->capture_default_str()->check(CLI::Range(0, 10));
  cmd->add_option("--plot", o->plots, "also plot this column (repeatable), e.g. flip, rays_traced, extra.<key>");
  cmd->add_option("--x-scale", o->x_scale, "x axis: auto, log or linear")
      ->check(CLI::IsMember({"auto", "log", "linear"}))->capture_default_str();
  cmd->add_option("--y-scale", o->y_scale, "y axes: auto, log or linear")
      ->check(CLI::IsMember({"auto", "log", "linear"}))->capture_default_str();
  cmd->add_flag("--pages", o->pages, "also write a comparison page per value to DIR/pages/<key>=<value>/");
  cmd->add_option("--cache-dir", o->cache_dir, "reference cache folder (default $PENUMBRA_CACHE_DIR or ~/.cache/penumbra)");
  cmd->add_flag("--no-cache", o->no_cache, "always render the ground truth, store nothing");
  cmd->add_option("--threads", o->threads, "worker threads (0 = all cores)")->capture_default_str()->check(CLI::Range(0, 1024));
  cmd->add_option("--device", o->device,
                  "where the methods render: cpu, gpu or gpu:N; a --methods entry NAME@gpu (or @cpu, @gpu:N) picks its "
                  "own, so CPU and GPU versions compare side by side (the ground truth renders on the CPU)")
      ->capture_default_str();
  cmd->add_flag("-q,--quiet", o->quiet, "no progress bar or summary");
  cmd->add_option("--dask", o->dask,
                  "run the jobs on the Dask scheduler at tcp://HOST:PORT (docs/distributed.md; needs the Python module)");
  cmd->add_option("--meshes", o->meshes, "with --dask: ship the mesh files to the workers, or read them from a shared path")
      ->check(CLI::IsMember({"ship", "shared"}))->capture_default_str();
  return [o] { return run_sweep_cli(*o); };
});

}  // namespace
}  // namespace penumbra::app
