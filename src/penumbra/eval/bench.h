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

struct BenchSuite {
  std::string name;                               // "quick", "full" or "custom"
  std::vector<std::filesystem::path> scenes;      // scene files
  int resolution = 128;                           // square images
  int light_samples = 16;
  int runs = 3;                                   // timed runs (median)
  int warmup_runs = 1;
};

// quick: 128^2, 16 light samples, 3 runs; full: 512^2, 256 light samples, 5 runs; both on
// bunny, contact, furball, knot and plant from `scenes_dir`.
BenchSuite bench_suite(const std::string& name, const std::filesystem::path& scenes_dir);

struct BenchOptions {
  BenchSuite suite;
  std::vector<std::string> methods;  // "reference" is added first when missing
  std::vector<std::string> params;   // run settings (RunSetup::apply), e.g. "lam.samples=64"
  bool progress = false;
  std::string command;               // recorded in the results
};

// Runs the suite; returns the bench-results.json document.
nlohmann::json run_bench(const BenchOptions& options);
// The Markdown table: one row per method, one column per scene, "time ms (speed-up x)".
std::string bench_markdown(const nlohmann::json& results);

}  // namespace penumbra
