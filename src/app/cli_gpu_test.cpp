// The command line on the GPU (issue 28): --device on render, compare and bench, `penumbra
// devices`, the devices column of `penumbra methods`, and the one-line errors that write nothing.
// Run like every GPU test: on the machine's Vulkan device (lavapipe in CI), failing rather than
// skipping without one where PENUMBRA_REQUIRE_GPU is set; a Vulkan validation message makes the
// tool exit with 3 (app/main.cpp), so these fail on one too.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/gpu/shaders.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/testing/cli_run.h"
#include "penumbra/testing/gpu_method_runs.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

namespace fs = std::filesystem;

class CliGpu : public gpu::testing::GpuTest {
 protected:
  using Run = penumbra::testing::CliRun;
  void SetUp() override {
    GpuTest::SetUp();
    dir_ = fs::temp_directory_path() / fmt::format("penumbra-cli-gpu-{}-{}", ::getpid(),
                                                   ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    fs::remove_all(dir_);
    GpuTest::TearDown();
  }
  Run run(const std::string& args) { return penumbra::testing::run_cli(dir_, args); }
  static std::string slurp(const fs::path& p) { return penumbra::testing::slurp(p); }
  static std::string scene(const std::string& name) { return std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name + ".json"; }
  // A refused run: exit 1, one line naming `names`, nothing written.
  void expect_refused(const std::string& args, const std::string& names) {
    const fs::path out = dir_ / "refused.png";
    const Run r = run(args + " -o " + out.string());
    EXPECT_EQ(r.exit_code, 1) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(names), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
  fs::path dir_;
};

TEST_F(CliGpu, RenderOnTheGpuWritesTheImageAndItsGpuTimes) {
  const fs::path out = dir_ / "x.exr", stats = dir_ / "s.json";
  const Run r = run(fmt::format("render {} --device gpu -m reference --spp 4 --resolution 32 -o {} --stats-json {}",
                                scene("bunny"), out.string(), stats.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out));
  EXPECT_NE(r.err.find("reference on gpu"), std::string::npos) << r.err;
  const nlohmann::json s = nlohmann::json::parse(slurp(stats));
  EXPECT_EQ(s["device"], device().info().name);
  for (const char* stage : {"camera_pass", "trace", "compose", "resolve", "total", "readback"})
    EXPECT_TRUE(s["gpu_ms"].contains(stage)) << stage;
  EXPECT_GT(s["stats"]["rays_traced"].get<uint64_t>(), 0u);
}

TEST_F(CliGpu, BadDevicesAndMethodsWithoutAGpuVersionAreOneLineErrors) {
  const std::string bunny = scene("bunny");
  expect_refused(fmt::format("render {} --device gpu:97 -m hard", bunny), "gpu:97: this machine has");
  expect_refused(fmt::format("render {} --device tpu -m hard", bunny), "--device tpu: expected cpu, gpu or gpu:N");
  const std::string cpu_only = testing::cpu_only_method();
  if (!cpu_only.empty())
    expect_refused(fmt::format("render {} --device gpu -m {}", bunny, cpu_only), cpu_only + " has no GPU version yet");
  expect_refused(fmt::format("render {} --device gpu -m reference --memory-limit 64K", bunny), "GPU memory");
}

TEST_F(CliGpu, AFailingVulkanCallIsOneLineAndWritesNothing) {
  for (const char* failure : {"allocation", "submission"}) {
    const fs::path out = dir_ / "x.png";
    const Run r = penumbra::testing::run_cli(
        dir_, fmt::format("render {} --device gpu -m hard --resolution 16 -o {}", scene("bunny"), out.string()),
        fmt::format("PENUMBRA_GPU_TEST_FAIL={}", failure));
    EXPECT_EQ(r.exit_code, 1) << failure << ": " << r.err;
    EXPECT_NE(r.err.find(std::string(failure) == "allocation" ? "vkAllocateMemory" : "vkQueueSubmit"), std::string::npos)
        << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
}

// `devices --compile`: every embedded kernel's pipeline built and timed, slowest first (the
// diagnosis for a driver that takes long over one kernel); --device cpu is a one-line error.
TEST_F(CliGpu, DevicesCompileTimesEveryKernel) {
  Run r = run("devices --compile --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json d = nlohmann::json::parse(r.out);
  EXPECT_EQ(d["device"], device().info().name);
  ASSERT_EQ(d["kernels"].size(), gpu::spirv_modules().size());
  double sum = 0, previous = d["kernels"][0]["ms"].get<double>();
  for (const nlohmann::json& k : d["kernels"]) {
    EXPECT_NE(gpu::find_spirv(k["kernel"].get<std::string>()), nullptr) << k;
    EXPECT_LE(k["ms"].get<double>(), previous) << k;
    previous = k["ms"].get<double>();
    sum += previous;
  }
  EXPECT_NEAR(d["total_ms"].get<double>(), sum, 1e-6 * sum + 1e-9);
  r = run("devices --compile");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("ssv_evaluate"), std::string::npos) << r.out;
  r = run("devices --compile --device cpu");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--device cpu"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

TEST_F(CliGpu, DevicesAndMethodsSayWhatRunsWhere) {
  Run r = run("devices");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("gpu:0"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(device().info().name), std::string::npos) << r.out;
  r = run("devices --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json d = nlohmann::json::parse(r.out);
  ASSERT_FALSE(d.empty());
  EXPECT_GT(d[0]["subgroup_size"].get<int>(), 0);
  r = run("methods --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const auto& m : nlohmann::json::parse(r.out)) {
    const bool gpu = std::find(m["devices"].begin(), m["devices"].end(), "gpu") != m["devices"].end();
    const std::string name = m["name"];
    if (name == "reference" || name == "hard" || name == "shadow-map" || name == "pcss" || name == "lam" ||
        name == "single-sample" || name == "multi-view-sm")
      EXPECT_TRUE(gpu) << name;
    // The registry's own answer for the others.
    EXPECT_EQ(gpu, find_gpu_method(name) != nullptr) << name;
  }
}

TEST_F(CliGpu, CompareRunsACpuAndAGpuVersionSideBySide) {
  const fs::path out = dir_ / "cmp";
  const Run r = run(fmt::format(
      "compare {} --methods reference,reference@gpu,hard@gpu,pcss@gpu:pcf_samples=8 --spp 4 --reference-spp 16 "
      "--resolution 24 --cache-dir {} -o {} -q",
      scene("bunny"), (dir_ / "cache").string(), out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json results = nlohmann::json::parse(slurp(out / "results.json"));
  int ok = 0;
  for (const auto& m : results["methods"]) {
    EXPECT_TRUE(m.value("ok", false)) << m.dump();
    ok += m.value("ok", false);
  }
  EXPECT_EQ(ok, 4);
  // A device name that is none, and a method without a GPU version, before anything renders.
  Run bad = run(fmt::format("compare {} --methods reference@tpu -o {} -q", scene("bunny"), (dir_ / "bad").string()));
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("device 'tpu'"), std::string::npos) << bad.err;
  const std::string cpu_only = testing::cpu_only_method();
  if (cpu_only.empty()) return;  // every method has a GPU version
  bad = run(fmt::format("compare {} --methods {}@gpu -o {} -q", scene("bunny"), cpu_only, (dir_ / "bad").string()));
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find(cpu_only + " has no GPU version"), std::string::npos) << bad.err;
}

// Issue 30's end check: every registered method runs on the GPU from one compare command, each
// row measured against the (GPU) ground truth.
TEST_F(CliGpu, CompareOnTheGpuRunsEveryMethod) {
  const fs::path out = dir_ / "all";
  const Run r = run(fmt::format("compare {} --device gpu --methods all --spp 16 --resolution 32 --cache-dir {} -o {} -q",
                                scene("bunny"), (dir_ / "cache").string(), out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json results = nlohmann::json::parse(slurp(out / "results.json"));
  size_t ok = 0;
  for (const auto& m : results["methods"]) {
    EXPECT_TRUE(m.value("ok", false)) << m.dump();
    ok += m.value("ok", false);
  }
  EXPECT_EQ(ok, MethodRegistry::all().size());
}

TEST_F(CliGpu, TheGpuBenchSuiteRunsAtASmallSize) {
  const fs::path out = dir_ / "bench";
  const Run r = run(fmt::format("bench --suite gpu --scenes-dir {}/scenes --scenes bunny --resolution 32 --spp 4 "
                                "--runs 1 --warmup 0 --methods reference,hard,shadow-map,pcss -o {} -q",
                                PENUMBRA_SOURCE_DIR, out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json b = nlohmann::json::parse(slurp(out / "bench-results.json"));
  EXPECT_EQ(b["device"]["name"], device().info().name);
  ASSERT_EQ(b["scenes"].size(), 1u);
  int ok = 0;
  for (const auto& m : b["scenes"][0]["methods"]) {
    EXPECT_TRUE(m.value("ok", false)) << m.dump();
    if (!m.value("ok", false)) continue;
    ++ok;
    EXPECT_GT(m["gpu"]["shadow_ms"].get<double>(), 0.0);
    EXPECT_GT(m["cpu"]["shadow_ms"].get<double>(), 0.0);
    EXPECT_GT(m["cpu_over_gpu"].get<double>(), 0.0);
    EXPECT_EQ(m["gpu"]["warmup_frames"], 0);  // --warmup 0 is kept: no frames added to warm the clocks
    if (m["method"] == "reference") EXPECT_GT(m["gpu"]["rays_per_s"].get<double>(), 0.0);
  }
  EXPECT_EQ(ok, 4);
  EXPECT_NE(slurp(out / "bench-results.md").find("| `reference` |"), std::string::npos);
}

// --no-cpu (issue 31's runs that vary a setting on the GPU): the GPU side alone, with the first
// frame's stages (what later frames reuse) and the method's counters.
TEST_F(CliGpu, TheGpuBenchSuiteWithoutItsCpuSide) {
  const fs::path out = dir_ / "bench-gpu-only";
  const Run r = run(fmt::format("bench --suite gpu --no-cpu --scenes-dir {}/scenes --scenes bunny --resolution 32 "
                                "--spp 4 --runs 2 --warmup 1 --methods vsm -o {} -q",
                                PENUMBRA_SOURCE_DIR, out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json b = nlohmann::json::parse(slurp(out / "bench-results.json"));
  EXPECT_FALSE(b["settings"]["cpu_side"].get<bool>());
  ASSERT_EQ(b["scenes"][0]["methods"].size(), 1u);  // reference is not added
  const nlohmann::json& m = b["scenes"][0]["methods"][0];
  ASSERT_TRUE(m.value("ok", false)) << m.dump();
  EXPECT_FALSE(m.contains("cpu"));
  EXPECT_FALSE(m.contains("cpu_over_gpu"));
  // Two runs, or one where the first frame took over 2 s (the bench's rule for slow methods),
  // as lavapipe's first frame at 32 x 32 once did with another test busy on both cores.
  const size_t runs = m["gpu"]["first_frame_ms"].value("total", 0.0) > 2000.0 ? 1 : 2;
  EXPECT_EQ(m["gpu"]["runs"], runs);
  EXPECT_EQ(m["gpu"]["run_shadow_ms"].size(), runs);
  // At least the one warm-up frame asked for; more while the GPU has been busy under 0.5 s (its
  // clocks), never over 100.
  EXPECT_GE(m["gpu"]["warmup_frames"].get<int>(), 1);
  EXPECT_LE(m["gpu"]["warmup_frames"].get<int>(), 100);
  // vsm rasterizes and prefilters its map in the first frame and reuses it after.
  EXPECT_GT(m["gpu"]["first_frame_ms"].value("raster", 0.0), 0.0);
  EXPECT_FALSE(m["gpu"]["stages_ms"].contains("raster")) << m["gpu"]["stages_ms"].dump();
  EXPECT_TRUE(m["gpu"]["stats"].contains("memory_bytes"));
  const std::string md = slurp(out / "bench-results.md");
  EXPECT_NE(md.find("not run (--no-cpu)"), std::string::npos);
  EXPECT_NE(md.find("| `vsm` |"), std::string::npos);

  // With kernel profiling: each frame's kernels, and the table of the costliest.
  const fs::path profiled = dir_ / "bench-profiled";
  const Run p = penumbra::testing::run_cli(
      dir_,
      fmt::format("bench --suite gpu --no-cpu --scenes-dir {}/scenes --scenes bunny --resolution 32 --spp 4 "
                  "--runs 1 --warmup 1 --methods vsm -o {} -q",
                  PENUMBRA_SOURCE_DIR, profiled.string()),
      "PENUMBRA_GPU_PROFILE=1");
  ASSERT_EQ(p.exit_code, 0) << p.err;
  const nlohmann::json pb = nlohmann::json::parse(slurp(profiled / "bench-results.json"));
  const nlohmann::json& pg = pb["scenes"][0]["methods"][0]["gpu"];
  EXPECT_TRUE(pg["first_frame_kernels"].contains("raster_fill")) << pg.dump();  // the map, first frame only
  EXPECT_FALSE(pg["kernels"].contains("raster_fill")) << pg.dump();
  EXPECT_TRUE(pg["kernels"].contains("fm_filter")) << pg.dump();
  EXPECT_NE(slurp(profiled / "bench-results.md").find("Kernels (PENUMBRA_GPU_PROFILE=1)"), std::string::npos);
  EXPECT_EQ(md.find("Kernels (PENUMBRA_GPU_PROFILE=1)"), std::string::npos);  // none without it

  const Run other = run("bench --suite quick --no-cpu -q");
  EXPECT_NE(other.exit_code, 0);
  EXPECT_NE(other.err.find("--no-cpu"), std::string::npos) << other.err;
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
