// penumbra compare SCENE [--methods a,b,c|all] [--spp N] [--reference-spp N] [-p key=value]... -o DIR
//                       [--frame-range A:B]
// Every method against the ground truth in one report: DIR/index.html, results.json,
// results.csv (docs/compare.md).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>

#include <fmt/format.h>

#include "app/command.h"
#include "penumbra/gpu/device.h"
#include "app/common.h"
#include "app/sequence.h"
#include "penumbra/core/parallel.h"
#include "penumbra/eval/comparison.h"
#include "penumbra/eval/report_util.h"
#include "penumbra/eval/temporal.h"
#include "penumbra/scene/animation.h"
#include "penumbra/scene/json_reader.h"

namespace penumbra::app {
namespace {

struct CompareCliOptions {
  std::string scene;
  std::vector<std::string> methods{"all"};
  int spp = 256;
  int reference_spp = 1024;
  std::string resolution;
  uint64_t seed = 0;
  std::vector<std::string> params;
  std::string output;
  int runs = 1;
  std::string cache_dir;
  bool no_cache = false;
  float heatmap_scale = 0;
  bool no_images = false;
  bool no_equal_quality = false;
  int threads = 0;
  std::string device = "cpu";  // --device: every method's unless its --methods entry names one
  bool quiet = false;
  std::string dask;             // a Dask scheduler's address: the jobs run there
  std::string meshes = "ship";  // with --dask: ship the mesh files, or read them from a shared path
  std::string frame_range;      // an animated scene's frames A:B (half-open): a sequence (issue 18)
  std::vector<std::string> objects;  // --objects: groups of objects with errors of their own
};

// A few columns of the table on stdout, for a terminal user.
// An equal-quality point as text: "63.2", ">=1024", "<=1", or a speed-up "0.83x", ">=2.1x".
std::string equal_quality_text(const EqualQuality& q, double v, bool speedup) {
  if (std::isnan(v)) return "-";
  const std::string bound = q.bound == QualityBound::kAtLeast ? ">=" : q.bound == QualityBound::kAtMost ? "<=" : "";
  return bound + (speedup ? format_significant(v, 3) + "x" : format_light_samples(v));
}

void print_summary(const Comparison& c) {
  std::printf("%-20s %11s %9s %8s %11s %9s", "method", "mean|dV|", "PSNR dB", "FLIP", "shadow ms", "speed-up");
  if (c.has_ladder) std::printf(" %10s %10s", "eq-|dV|spp", "eq-speedup");
  if (c.has_frames) std::printf(" %11s %11s %11s", "instability", "ms/f reuse", "ms/f fresh");
  std::printf("\n");
  for (const MethodRun& r : c.runs) {
    if (!r.ok) {
      std::printf("%-20s failed: %s\n", r.method.c_str(), r.error.c_str());
      continue;
    }
    auto num = [](double v, int digits) { return std::isnan(v) ? std::string("-") : format_significant(v, digits); };
    std::string psnr = std::isnan(r.color_psnr) ? "-" : std::isinf(r.color_psnr) ? "inf" : fmt::format("{:.2f}", r.color_psnr);
    std::printf("%-20s %11s %9s %8s %11s %9s", r.method.c_str(), num(r.v.mae, 3).c_str(), psnr.c_str(),
                num(r.flip, 3).c_str(), num(r.times.shadow_ms, 4).c_str(),
                std::isnan(r.speedup) ? "-" : (format_significant(r.speedup, 3) + "x").c_str());
    if (c.has_ladder)
      std::printf(" %10s %10s", equal_quality_text(r.eq_v, r.eq_v.samples, false).c_str(),
                  equal_quality_text(r.eq_v, r.eq_v.speedup, true).c_str());
    if (c.has_frames) {
      for (const MethodFrames& f : c.frames.methods) {
        if (f.method != r.method) continue;
        if (f.ok)
          std::printf(" %11s %11s %11s", num(f.temporal_instability, 3).c_str(), num(f.ms_per_frame_reuse, 4).c_str(),
                      num(f.ms_per_frame_fresh, 4).c_str());
        else
          std::printf("  %s", f.error.c_str());
      }
    }
    std::printf("\n");
  }
  // --objects: each method's error over each group's pixels.
  if (!c.object_groups.empty()) {
    std::printf("mean |dV| (signed) by object:\n%-20s", "method");
    for (const ObjectGroup& g : c.object_groups)
      std::printf(" %22s", fmt::format("{} ({} px)", g.pattern, g.pixels).c_str());
    std::printf("\n");
    for (const MethodRun& r : c.runs) {
      if (!r.ok) continue;
      std::printf("%-20s", r.method.c_str());
      for (size_t g = 0; g < c.object_groups.size(); ++g) {
        const bool has = g < r.v_objects.size() && !std::isnan(r.v_objects[g].mae);
        std::printf(" %22s", has ? fmt::format("{} ({:+.2g})", format_significant(r.v_objects[g].mae, 3),
                                               r.v_objects[g].mean_signed).c_str()
                                 : "-");
      }
      std::printf("\n");
    }
  }
  // The wide-scene line (issue 34): which methods lose to the exact hard shadow here.
  for (const MethodRun& r : c.runs)
    if (r.ok && r.method == "hard" && c.has_ground_truth) {
      const std::vector<std::string> worse = worse_than_hard(c);
      std::string names;
      for (const std::string& m : worse) names += (names.empty() ? "" : ", ") + m;
      std::printf("worse than hard (mean |dV| %s): %s\n", format_significant(r.v.mae, 3).c_str(),
                  worse.empty() ? "none" : names.c_str());
    }
  // What the speed-ups divide, and whether its time was measured now (issue 32).
  if (const std::string basis = speedup_basis_text(c); !basis.empty()) std::printf("speed-up over %s\n", basis.c_str());
  if (c.has_ladder && !c.ladder.rungs.empty())
    std::printf("eq-speedup over the reference ladder at 1-%d light samples (times %s)\n",
                c.ladder.rungs.back().light_samples, ladder_time_basis_text(c.ladder).c_str());
}

int run_compare(const CompareCliOptions& o) {
  ThreadLimit limit(o.threads);
  RunSetup setup = RunSetup::from_file(o.scene);
  setup.light_samples = o.spp;
  setup.reference_samples = o.reference_spp;
  setup.seed = o.seed;
  setup.device = gpu::DeviceChoice::parse(o.device).to_string();
  if (!o.resolution.empty()) setup.apply("resolution", o.resolution);
  for (const std::string& kv : o.params) setup.apply(kv);
  CompareOptions co;
  co.methods = expand_method_list(o.methods);
  co.runs = o.runs;
  co.progress = !o.quiet;
  co.equal_quality = !o.no_equal_quality;
  co.objects = o.objects;
  co.cache_dir = o.no_cache ? std::filesystem::path() : o.cache_dir.empty() ? default_cache_dir() : std::filesystem::path(o.cache_dir);
  std::string out = o.output.empty() ? fmt::format("compare-{}", std::filesystem::path(o.scene).stem().string()) : o.output;

  // A sequence: the range is checked against the scene's frames before any render.
  std::optional<FrameRange> range;
  if (!o.frame_range.empty()) {
    const std::string asked = "--frame-range " + o.frame_range;
    if (!o.dask.empty()) throw Error("{}: not available with --dask (compare the frames locally)", asked);
    if (!o.objects.empty()) throw Error("{}: not available with --objects (the objects' pixels move from frame to frame)", asked);
    if (!setup.scene_doc.contains("animation"))
      throw Error("{}: {} has no \"animation\" block (docs/scene-format.md)", asked, o.scene);
    const nlohmann::json& frames = setup.scene_doc["animation"].is_object()
                                       ? setup.scene_doc["animation"].value("frames", nlohmann::json())
                                       : nlohmann::json();
    // A block the loader would reject: load it for its own message.
    const int count = frames.is_number_integer() ? frames.get<int>() : setup.load().animation->frames;
    range = parse_frame_range(o.frame_range, count, "--frame-range");
  }

  // --objects: not on a cluster; a pattern that names no object fails before the output folder is made.
  if (!o.objects.empty() && !o.dask.empty()) throw Error("--objects: not available with --dask (compare locally)");
  if (!o.objects.empty() && !range) match_object_patterns(setup.load(), o.objects);
  make_output_folder(out);  // before any render: a bad -o fails at once
  Comparison c;
  if (!o.dask.empty()) {
    // The same comparison as jobs on the cluster (docs/distributed.md); penumbra.distributed
    // writes the same report, read back here for the summary.
    setup.check_plain_params(co.methods);
    const nlohmann::json request = {{"command", "compare"},
                                    {"setup", run_setup_json(setup)},
                                    {"methods", co.methods},
                                    {"runs", co.runs},
                                    {"equal_quality", co.equal_quality},
                                    {"cache_dir", co.cache_dir.string()},
                                    {"meshes", o.meshes},
                                    {"output", std::filesystem::absolute(out).string()},
                                    {"heatmap_scale", o.heatmap_scale},
                                    {"write_images", !o.no_images},
                                    {"command_line", command_line()}};
    if (const int code = run_on_dask(request, o.dask); code != 0) return code;
    c = comparison_from_json(read_json_file(std::filesystem::path(out) / "results.json"));
  } else {
    c = range ? run_sequence_comparison(setup, co, range->begin, range->end) : run_comparison(setup, co);
    c.command = command_line();
    ReportOptions ro;
    ro.heatmap_scale = o.heatmap_scale;
    ro.write_images = !o.no_images;
    write_comparison(c, out, ro);
  }
  if (!o.quiet) {
    print_summary(c);
    int failed = 0;
    for (const auto& r : c.runs) failed += r.ok ? 0 : 1;
    std::fprintf(stderr, "%s: %zu methods (%d failed), ground truth %s; %.1f s -> %s/index.html\n", o.scene.c_str(),
                 c.runs.size(), failed, c.truth.from_cache ? "from the cache" : "rendered", c.wall_ms / 1000,
                 out.c_str());
  }
  return 0;
}

const CommandRegistration compare_command("compare", 50, [](CLI::App& app) {
  auto o = std::make_shared<CompareCliOptions>();
  CLI::App* cmd = app.add_subcommand("compare", "every method against the ground truth: an HTML page, JSON and CSV");
  cmd->add_option("scene", o->scene, "scene file (JSON)")->required();
  cmd->add_option("--methods", o->methods, "methods to compare, comma-separated, or 'all'")
      ->delimiter(',')->capture_default_str();
  cmd->add_option("--spp", o->spp, "light samples of every method that samples the light")
      ->capture_default_str()->check(CLI::Range(1, 1 << 20));
  cmd->add_option("--reference-spp", o->reference_spp, "light samples of the ground truth (the reference)")
      ->capture_default_str()->check(CLI::Range(1, 1 << 20));
  cmd->add_option("--resolution", o->resolution, "image size N or WxH (overrides the scene's camera)");
  cmd->add_option("--seed", o->seed, "random seed")->capture_default_str();
  cmd->add_option("-p,--param", o->params,
                  "setting key=value (repeatable): <method>.<param>, <param> (every method declaring it), "
                  "light.size_scale, light.size, light.radius, generator.<param>, pixel_samples, ...");
  cmd->add_option("-o,--output", o->output, "output folder (default compare-<scene>)");
  cmd->add_option("--runs", o->runs, "timed renders per method (the median is reported)")
      ->capture_default_str()->check(CLI::Range(1, 100));
  cmd->add_option("--cache-dir", o->cache_dir, "reference cache folder (default $PENUMBRA_CACHE_DIR or ~/.cache/penumbra)");
  cmd->add_flag("--no-cache", o->no_cache, "always render the ground truth, store nothing");
  cmd->add_option("--heatmap-scale", o->heatmap_scale, "|dV| at the end of the heat-map colour scales (0: automatic)")
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_flag("--no-images", o->no_images, "do not write DIR/images/*.exr");
  cmd->add_flag("--no-equal-quality", o->no_equal_quality,
                "do not render the reference ladder (1, 2, 4, ... light samples) for the equal-quality columns");
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
  cmd->add_option("--frame-range", o->frame_range,
                  "an animated scene's frames A:B (half-open; A:, :B, :): each frame against its own ground truth, "
                  "with temporal instability and the cost per frame with and without reuse");
  cmd->add_option("--objects", o->objects,
                  "also measure every method's V error over the pixels showing these objects, each a name or a "
                  "shell-style pattern over object names (ground,'*.leaves'): where the error lives")
      ->delimiter(',');
  return [o] { return run_compare(*o); };
});

}  // namespace
}  // namespace penumbra::app
