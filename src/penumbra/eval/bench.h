// The performance suite (`penumbra bench`): every method on the scene suite at fixed
// settings, each timed as the median of several runs after a warm-up, reported as a ratio
// to `reference` (ray tracing on Embree at the same light samples) measured in the same
// run. Writes bench-results.json and a Markdown table (docs/benchmarks.md quotes it).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace penumbra {

// One target of the perf suite (issue 14 part 2): a method on a scene at fixed settings, and
// the goal it must reach: a speed-up over `reference` at the same light samples, measured side
// by side in the same run, or an absolute time.
struct PerfTarget {
  enum class Kind { kSpeedup, kTime };
  std::string method;              // "afsm"
  std::string scene;               // a scene of the suite folder ("bunny")
  int light_samples = 256;
  int resolution = 0;              // square; 0: the suite's resolution (the ratio targets, 256^2)
  Kind kind = Kind::kSpeedup;
  // kTime: what is timed: "total_ms" (the whole frame, camera pass included) or "phase:<name>"
  // (one of the method's phases, e.g. "phase:display"); kSpeedup: the shadow time.
  std::string measure = "shadow_ms";
  double goal = 1;                 // kSpeedup: the least speed-up; kTime: the most ms (below it)
  std::vector<std::string> params; // settings of this target (RunSetup::apply)
};

// The targets of issue 14 part 2, in the order the issue names them.
const std::vector<PerfTarget>& perf_targets();
// "afsm, 1024 spp, bunny: speed-up over reference >= 2x" and the like.
std::string perf_target_label(const PerfTarget& t, int suite_resolution);

struct BenchSuite {
  std::string name;                               // "quick", "full", "perf" or "custom"
  std::vector<std::filesystem::path> scenes;      // scene files
  int resolution = 128;                           // image width (square unless height > 0)
  int height = 0;                                 // the gpu suite: 1080 (1920 x 1080)
  int light_samples = 16;
  int runs = 3;                                   // timed runs (median)
  int warmup_runs = 1;
  // Non-empty: a target suite (perf): every target's method and reference are run on its
  // scene, interleaved, and the result is PASS or MISS per target.
  std::vector<PerfTarget> targets;
  // > 0: a sequence suite (walk, issue 18 part 6): the animated scenes' frames 0 .. N-1, each
  // method rendering them one after another with the reuse of render/sequence_renderer.h, the
  // methods interleaved frame by frame; a method's cost is the median over frames 1 .. N-1
  // (once its light-space structures exist), its first frame reported apart.
  int sequence_frames = 0;
  // A sequence suite's targets: the least per-frame speed-up over `reference` of a method on
  // a scene (the "lam on the camera walk at least 50x").
  std::vector<PerfTarget> sequence_targets;
  // The gpu suite (issue 28 part 7): every method with a GPU version on the GPU and on the
  // CPU side by side (eval/bench_gpu.cpp), not against reference.
  bool devices = false;
  // > 0 (the wide suite, issue 34 part 4): every method's mean |dV| against the ground truth at
  // this many light samples (the compare cache's, default_cache_dir()) beside its time.
  int reference_spp = 0;
  // With reference_spp > 0: per scene (its file's stem), groups of objects whose pixels each
  // method's error is also measured over (compare --objects, eval/object_errors.h): the wide
  // suite splits its scenes into the ground and the casters, where the error lives.
  std::vector<std::pair<std::string, std::vector<std::string>>> object_groups;
};

// quick: 128^2, 16 light samples, 3 runs; full: 512^2, 256 light samples, 5 runs; both on
// bunny, contact, furball, knot and plant from `scenes_dir`. perf: perf_targets() on bunny and
// plant, 256^2 for the ratio targets (the time targets fix their own 512^2), 5 runs. walk:
// bunny-walk, plant-light and furball-spin, 8 frames at 256^2, 256 light samples. wide: the
// forest of 100 trees (forest-100, 5.9 M triangles, issue 32) at 256^2, 64 light samples, one
// run; each scene's entry also has its load time, Embree build and peak memory. gpu: bunny and
// plant at 1920x1080, 256 light samples, 5 runs after 1 warm-up on the GPU (BenchSuite::devices).
BenchSuite bench_suite(const std::string& name, const std::filesystem::path& scenes_dir);

struct BenchOptions {
  BenchSuite suite;
  // "reference" is added first when missing. A target suite: only the targets of these
  // methods (empty: every target).
  std::vector<std::string> methods;
  std::vector<std::string> params;   // run settings (RunSetup::apply), e.g. "lam.samples=64"
  bool progress = false;
  std::string command;               // recorded in the results
  // --device: where every method renders (cpu, gpu, gpu:N); the gpu suite's GPU side.
  std::string device = "cpu";
  // The gpu suite: also time each method's CPU version (false: the GPU side alone, for runs
  // that vary a setting on the GPU, issue 31).
  bool cpu_side = true;
};

// Runs the suite; returns the bench-results.json document.
nlohmann::json run_bench(const BenchOptions& options);
// The Markdown table: one row per method, one column per scene, "time ms (speed-up x)"; for a
// target suite, first the targets with their measured value and PASS or MISS.
std::string bench_markdown(const nlohmann::json& results);

// The bench-results.json document every suite writes: the suite's name, its `settings`, the
// `timing` sentence that says what the times are, the methods, the machine, when it started, how
// long it took, the command, and the suite's `scenes`.
nlohmann::json bench_document(const BenchOptions& o, nlohmann::json settings, const std::string& timing,
                              const std::vector<std::string>& methods, const std::string& started, double wall_ms,
                              nlohmann::json scenes);

// The gpu suite (BenchSuite::devices; run_bench calls it) and its Markdown.
nlohmann::json run_gpu_suite(const BenchOptions& options);
std::string gpu_bench_markdown(const nlohmann::json& results);

}  // namespace penumbra
