// penumbra bench [--suite quick|full|perf|walk|wide] [--methods ...] [--scenes a,b] [-o DIR]
// The performance suite: every method on the scene suite, median of several runs, as a
// ratio to `reference` measured in the same run (docs/benchmarks.md).
#include <cstdio>
#include <filesystem>

#include <fmt/format.h>

#include "app/command.h"
#include "penumbra/gpu/device.h"
#include "app/common.h"
#include "penumbra/core/file_util.h"
#include "penumbra/core/parallel.h"
#include "penumbra/eval/bench.h"
#include "penumbra/eval/run_setup.h"

namespace penumbra::app {
namespace {

namespace fs = std::filesystem;

struct BenchCliOptions {
  std::string suite = "quick";
  std::vector<std::string> methods{"all"};
  std::vector<std::string> scenes;
  std::string scenes_dir = "scenes";
  int runs = 0, resolution = 0, spp = 0, warmup = -1;
  std::vector<std::string> params;
  std::string output = ".";
  int threads = 0;
  std::string device = "cpu";
  bool quiet = false;
  bool no_cpu = false;
};

int run_bench_cli(const BenchCliOptions& o) {
  ThreadLimit limit(o.threads);
  BenchOptions bo;
  bo.suite = bench_suite(o.suite, o.scenes_dir);
  if (!o.scenes.empty()) {
    bo.suite.scenes.clear();
    for (const auto& item : o.scenes)
      for (const auto& name : split_list(item)) {
        // A name from the suite folder ("bunny") or a path to a scene file.
        fs::path p = name;
        if (!fs::exists(p)) p = fs::path(o.scenes_dir) / (name + ".json");
        if (!fs::exists(p)) throw Error("--scenes {}: no such scene ({} does not exist)", name, p.string());
        bo.suite.scenes.push_back(p);
      }
  }
  if (!bo.suite.targets.empty() && o.spp > 0)
    throw Error("--spp {}: the {} suite's targets fix their own light samples", o.spp, o.suite);
  if (bo.suite.sequence_frames > 0 && (o.runs > 0 || o.warmup >= 0))
    throw Error("--runs/--warmup: the {} suite times every frame once (the frames are its runs)", o.suite);
  if (o.runs > 0) bo.suite.runs = o.runs;
  if (o.resolution > 0) {
    // The gpu suite keeps its 16:9 frame: --resolution sets its width.
    if (bo.suite.height > 0) bo.suite.height = std::max(1, o.resolution * 9 / 16);
    bo.suite.resolution = o.resolution;
  }
  if (o.spp > 0) bo.suite.light_samples = o.spp;
  if (o.warmup >= 0) bo.suite.warmup_runs = o.warmup;
  bool custom = !o.scenes.empty() || o.runs > 0 || o.resolution > 0 || o.spp > 0 || o.warmup >= 0;
  if (custom) bo.suite.name += " (modified)";
  bo.methods = expand_method_list(o.methods);
  bo.device = gpu::DeviceChoice::parse(o.device).to_string();  // a bad value fails before anything runs
  bo.params = o.params;
  if (o.no_cpu && o.suite != "gpu")
    throw Error("--no-cpu: only the gpu suite has a CPU side to leave out (--suite {})", o.suite);
  bo.cpu_side = !o.no_cpu;
  bo.progress = !o.quiet;
  bo.command = command_line();
  fs::create_directories(o.output);

  nlohmann::json r = run_bench(bo);
  std::string md = bench_markdown(r);
  write_text_file_atomic(fs::path(o.output) / "bench-results.json", r.dump(2) + "\n");
  write_text_file_atomic(fs::path(o.output) / "bench-results.md", md);
  if (!o.quiet) {
    std::printf("%s", md.c_str());
  } else if (r.contains("targets")) {
    // Quiet: the targets' results alone, one line each.
    for (const auto& t : r["targets"])
      std::printf("%s %s\n", t.value("result", "?").c_str(), t.value("target", "?").c_str());
  }
  if (!o.quiet) {
    std::fprintf(stderr, "bench %s: %.1f s -> %s/bench-results.json, bench-results.md\n", bo.suite.name.c_str(),
                 r.value("wall_ms", 0.0) / 1000, o.output.c_str());
  }
  return 0;
}

const CommandRegistration bench_command("bench", 70, [](CLI::App& app) {
  auto o = std::make_shared<BenchCliOptions>();
  CLI::App* cmd = app.add_subcommand("bench", "performance suite: every method on the scene suite, as a ratio to reference");
  cmd->add_option("--suite", o->suite, "quick (128^2, 16 spp, 3 runs), full (512^2, 256 spp, 5 runs), gpu (every GPU method "
                  "against its CPU version, 1920x1080, 256 spp) or perf (issue 14's targets: "
                  "ratios at 256^2 interleaved with reference, times at 512^2; PASS/MISS per target) or walk (the animated "
                  "scenes' frames 0-7 at 256^2, 256 spp: cost per frame with reuse; lam >= 50x reference per frame) or wide "
                  "(the bunny, the 25-tree forest, a street and the 100-tree forest at 256^2, 256 spp, one run: each method's error "
                  "against the 1024-spp ground truth beside its time, and the wide scenes as multiples of the bunny)")
      ->check(CLI::IsMember({"quick", "full", "perf", "walk", "wide", "gpu"}))->capture_default_str();
  cmd->add_option("--methods", o->methods, "methods, comma-separated, or 'all' (reference is always added; perf: their targets only)")
      ->delimiter(',')->capture_default_str();
  cmd->add_option("--scenes", o->scenes, "scenes instead of the suite's: names in --scenes-dir or files")->delimiter(',');
  cmd->add_option("--scenes-dir", o->scenes_dir, "folder of the scene suite")->capture_default_str();
  cmd->add_option("--runs", o->runs, "timed runs per method and scene, the median is reported (overrides the suite)")->check(CLI::Range(1, 100));
  cmd->add_option("--warmup", o->warmup, "untimed runs before them (overrides the suite)")->check(CLI::Range(0, 10));
  cmd->add_option("--resolution", o->resolution, "square image size (overrides the suite; perf: the speed-up targets only)")->check(CLI::Range(1, 16384));
  cmd->add_option("--spp", o->spp, "light samples (overrides the suite)")->check(CLI::Range(1, 1 << 20));
  cmd->add_option("-p,--param", o->params, "setting key=value for every scene (repeatable), e.g. lam.samples=64");
  cmd->add_option("-o,--output", o->output, "folder for bench-results.json and bench-results.md")->capture_default_str();
  cmd->add_option("--threads", o->threads, "worker threads (0 = all cores)")->capture_default_str()->check(CLI::Range(0, 1024));
  cmd->add_option("--device", o->device,
                  "where the methods render: cpu, gpu or gpu:N (the gpu suite: which GPU; docs/gpu.md)")
      ->capture_default_str();
  cmd->add_flag("--no-cpu", o->no_cpu, "the gpu suite: time the GPU side alone (no CPU runs, no CPU/GPU ratio)");
  cmd->add_flag("-q,--quiet", o->quiet, "no progress bar or table");
  return [o] { return run_bench_cli(*o); };
});

}  // namespace
}  // namespace penumbra::app
