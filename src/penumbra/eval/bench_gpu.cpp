// `penumbra bench --suite gpu` (issue 28 part 7, issue 31): every method that has a GPU version,
// on the GPU and on this machine's CPU cores at the same settings in the same run. The GPU side
// is timed by its timestamps (the GPU time of every stage of the frame; the read-back apart) as
// the median of several runs after a warm-up (every method's GPU side before any CPU side, so the
// GPU is not left idle between them); the CPU side once, at a quarter of the pixels where the
// whole frame would take over 10 s (the table says so and compares per pixel).
#include <algorithm>
#include <filesystem>
#include <sstream>

#include <fmt/format.h>

#include "penumbra/core/error.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/eval/bench.h"
#include "penumbra/eval/comparison.h"
#include "penumbra/eval/report_util.h"
#include "penumbra/eval/run_setup.h"
#include "penumbra/gpu/device.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/gpu_method.h"

namespace penumbra {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// A CPU render estimated to take longer than this at the suite's size renders at half the
// width and height instead (issue 31).
constexpr double kCpuBudgetMs = 10000;
// A method whose first GPU frame takes longer than this is timed by one run after it.
constexpr double kGpuSlowFrameMs = 2000;
// Warm-up frames run for at least this long (and at least the suite's count, at most
// kGpuWarmupFramesMost): an idle GPU lowers its clocks, and one warm-up frame after seconds of
// idling does not raise them. H200, 2026-11-28: the same 1920x1080 camera pass took 2.15 ms in
// the frames timed after a CPU run and 0.44 ms in frames timed back to back (docs/benchmarks.md).
constexpr double kGpuWarmupMs = 500;
constexpr int kGpuWarmupFramesMost = 100;

// The median of each stage over the runs (stage names as the first run lists them).
json median_stages(const std::vector<json>& runs) {
  json out = json::object();
  if (runs.empty()) return out;
  for (auto it = runs[0].begin(); it != runs[0].end(); ++it) {
    std::vector<double> v;
    for (const json& r : runs) v.push_back(r.value(it.key(), 0.0));
    out[it.key()] = median_of(v);
  }
  return out;
}

Scene scene_at(const RunSetup& setup, int width, int height) {
  RunSetup s = setup;
  s.apply("resolution", fmt::format("{}x{}", width, height));
  return s.load();
}

json gpu_side(const RunSetup& setup, const std::string& method, int width, int height, const BenchSuite& suite,
              Progress& bar) {
  const Scene scene = scene_at(setup, width, height);
  RenderSettings settings = method_render_settings(setup, method + "@" + setup.device);
  Renderer renderer(scene, settings);
  std::vector<double> shadow, frame;
  std::vector<json> stages;
  json first_frame, first_kernels, kernels, stats;
  uint64_t rays = 0;
  int runs = suite.runs;
  int warmup = suite.warmup_runs;
  const Timer warming;
  for (int i = 0; i < warmup + runs; ++i) {
    throw_if_interrupted();
    const RenderResult r = renderer.render();
    if (i < suite.warmup_runs + suite.runs) bar.add(1);
    if (i == 0) {
      // The first frame pays what later frames reuse (maps, slices, a precompute): its stages
      // are kept apart. A method that slow is timed once, so one method cannot eat a lease.
      first_frame = r.gpu_ms;
      first_kernels = r.gpu_kernels;
      if (r.gpu_ms.value("total", 0.0) > kGpuSlowFrameMs && runs > 1) {
        bar.add(runs - 1);
        runs = 1;
      }
    }
    // More warm-up frames while the GPU has been busy for less than kGpuWarmupMs (its clocks).
    if (i + 1 == warmup && warmup < kGpuWarmupFramesMost && warming.elapsed_ms() < kGpuWarmupMs &&
        first_frame.value("total", 0.0) <= kGpuSlowFrameMs)
      ++warmup;
    if (i < warmup) continue;
    shadow.push_back(shadow_time_ms(r));
    frame.push_back(r.gpu_ms.value("total", 0.0));
    stages.push_back(r.gpu_ms);
    rays = r.stats.rays_traced;
    if (stats.is_null()) {
      stats = r.stats.to_json();
      kernels = r.gpu_kernels;
    }
  }
  json out = {{"resolution", {width, height}},
              {"shadow_ms", median_of(shadow)},
              {"frame_ms", median_of(frame)},
              {"runs", runs},
              {"warmup_frames", warmup},
              {"run_shadow_ms", shadow},
              {"stages_ms", median_stages(stages)},
              {"first_frame_ms", first_frame},
              {"stats", stats}};
  // Kernel profiling (PENUMBRA_GPU_PROFILE=1): where the first and the first timed frame's time went.
  if (!first_kernels.is_null()) out["first_frame_kernels"] = first_kernels;
  if (!kernels.is_null()) out["kernels"] = kernels;
  if (rays > 0) {
    out["rays_traced"] = rays;
    const double trace_ms = out["stages_ms"].value("trace", 0.0);
    if (trace_ms > 0) out["rays_per_s"] = static_cast<double>(rays) / (trace_ms * 1e-3);
  }
  return out;
}

json cpu_side(const RunSetup& setup, const std::string& method, int width, int height, Progress& bar) {
  RenderSettings settings = method_render_settings(setup, method + "@cpu");
  // A probe at half the width and height: over a quarter of the budget there, it stays there.
  const int hw = std::max(1, width / 2), hh = std::max(1, height / 2);
  const RenderResult probe = Renderer(scene_at(setup, hw, hh), settings).render();
  bar.add(1);
  const bool reduced = probe.total_ms * 4 > kCpuBudgetMs;
  const RenderResult r = reduced ? probe : Renderer(scene_at(setup, width, height), settings).render();
  if (!reduced) bar.add(1);
  const int w = reduced ? hw : width, h = reduced ? hh : height;
  return {{"resolution", {w, h}},
          {"reduced", reduced},
          {"shadow_ms", shadow_time_ms(r)},
          {"total_ms", r.total_ms},
          {"rays_traced", r.stats.rays_traced}};
}

// With kernel profiling: per method, the kernels that took most of the first and of a later frame.
std::string kernel_table(const json& methods) {
  auto top = [](const json& kernels) {
    std::vector<std::pair<double, std::string>> v;
    for (auto it = kernels.begin(); it != kernels.end(); ++it)
      v.emplace_back(it.value().value("ms", 0.0), it.key());
    std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    std::string out;
    for (size_t i = 0; i < v.size() && i < 5; ++i)
      out += (i ? ", " : "") + v[i].second + " " + format_significant(v[i].first, 3) + " (" +
             std::to_string(kernels[v[i].second].value("dispatches", 0)) + ")";
    return out.empty() ? std::string("—") : out;
  };
  std::ostringstream md;
  bool any = false;
  for (const json& m : methods) {
    if (!m.value("ok", false) || !m["gpu"].contains("first_frame_kernels")) continue;
    if (!any)
      md << "Kernels (PENUMBRA_GPU_PROFILE=1): the five that took most GPU time, in ms (dispatches)\n\n"
         << "| method | first frame | a later frame |\n|---|---|---|\n";
    any = true;
    md << "| `" << m.value("method", "?") << "` | " << top(m["gpu"]["first_frame_kernels"]) << " | "
       << (m["gpu"].contains("kernels") ? top(m["gpu"]["kernels"]) : std::string("—")) << " |\n";
  }
  if (any) md << "\n";
  return md.str();
}

double per_pixel(const json& side) {
  const double pixels = side["resolution"][0].get<double>() * side["resolution"][1].get<double>();
  return side.value("shadow_ms", 0.0) / std::max(1.0, pixels);
}

}  // namespace

json run_gpu_suite(const BenchOptions& o) {
  Timer wall;
  const std::string started = local_time_iso();
  const BenchSuite& suite = o.suite;
  const gpu::DeviceChoice device = gpu::DeviceChoice::parse(o.device == "cpu" ? "gpu" : o.device);
  const gpu::DeviceInfo info = gpu::Device::get(device).info();
  // Every method with a GPU version (or those of --methods that have one), reference first.
  std::vector<std::string> methods;
  for (const std::string& m : o.methods) {
    const std::string name = parse_method_spec(m).name;
    if (find_gpu_method(name) && std::find(methods.begin(), methods.end(), name) == methods.end())
      methods.push_back(name);
  }
  if (methods.empty()) throw Error("bench --suite gpu: none of the methods asked for has a GPU version");
  std::stable_partition(methods.begin(), methods.end(), [](const std::string& m) { return m == "reference"; });
  const int width = suite.resolution, height = suite.height > 0 ? suite.height : suite.resolution;
  std::vector<RunSetup> setups;
  for (const fs::path& f : suite.scenes) {
    RunSetup setup = RunSetup::from_file(f);
    setup.apply("spp", std::to_string(suite.light_samples));
    for (const std::string& kv : o.params) setup.apply(kv);
    setup.check_plain_params(methods);
    setup.device = device.to_string();
    setups.push_back(std::move(setup));
  }
  Progress bar("bench gpu",
               setups.size() * methods.size() *
                   static_cast<uint64_t>(suite.warmup_runs + suite.runs + (o.cpu_side ? 2 : 0)),
               o.progress);
  json scenes = json::array();
  for (const RunSetup& setup : setups) {
    json ms = json::array();
    uint64_t triangles = 0;
    // Every method's GPU side first, then the CPU sides: a CPU run between two GPU methods would
    // leave the GPU idle for seconds, and the next method's frames would start at idle clocks.
    for (const std::string& method : methods) {
      json m = {{"method", method}};
      try {
        m["gpu"] = gpu_side(setup, method, width, height, suite, bar);
        m["ok"] = true;
      } catch (const Interrupted&) {
        throw;
      } catch (const std::exception& e) {
        m["ok"] = false;
        m["error"] = e.what();
      }
      ms.push_back(m);
    }
    for (json& m : ms) {
      if (!o.cpu_side || !m["ok"].get<bool>()) continue;
      try {
        m["cpu"] = cpu_side(setup, m["method"].get<std::string>(), width, height, bar);
        m["cpu_over_gpu"] = per_pixel(m["cpu"]) / std::max(1e-12, per_pixel(m["gpu"]));
      } catch (const Interrupted&) {
        throw;
      } catch (const std::exception& e) {
        m["ok"] = false;
        m["error"] = e.what();
      }
    }
    try {
      triangles = setup.load().triangle_count();
    } catch (const std::exception&) {
    }
    scenes.push_back({{"scene", setup.scene_path.string()},
                      {"name", setup.scene_path.stem().string()},
                      {"triangles", triangles},
                      {"methods", ms}});
  }
  bar.finish();
  json out = bench_document(
      o,
      {{"resolution", {width, height}},
       {"spp", suite.light_samples},
       {"runs", suite.runs},
       {"warmup_runs", suite.warmup_runs},
       {"cpu_side", o.cpu_side}},
      "gpu: GPU time of the method's stages (timestamps; shadow_ms) and of the whole frame (frame_ms, read-back "
      "apart), median of the runs (one run where the first frame took over 2 s: gpu.runs), first_frame_ms: the "
      "stages of the first frame, which pays what later ones reuse, stats: the method's counters; cpu: the same "
      "method on this machine's cores once, shadow_ms = total - camera pass - compose, at half the width and "
      "height where the whole frame would take over 10 s; cpu_over_gpu: the ratio of the shadow times per pixel",
      methods, started, wall.elapsed_ms(), scenes);
  out["device"] = {{"name", info.name}, {"type", info.type}, {"driver", info.driver}, {"vulkan", info.api_version},
                   {"memory_bytes", info.memory_bytes}, {"subgroup_size", info.subgroup_size}};
  return out;
}

std::string gpu_bench_markdown(const json& r) {
  std::ostringstream md;
  const json& st = r.at("settings");
  const json& dev = r.at("device");
  const json& mc = r.at("machine");
  const int warmup = st.value("warmup_runs", 0);
  md << fmt::format("Suite `{}`: {}×{} pixels, {} light samples; GPU: {} ({}, {}), median of {} runs after {} warm-up{}, "
                    "timed by its timestamps; CPU: {}, {} threads, {}; {}.\n\n",
                    r.value("suite", "?"), st["resolution"][0].get<int>(), st["resolution"][1].get<int>(),
                    st.value("spp", 0), dev.value("name", "?"), dev.value("driver", "?"), dev.value("type", "?"),
                    st.value("runs", 0), warmup, warmup > 0 ? " (more while the GPU has been busy under 0.5 s)" : "",
                    mc.value("cpu", "?"), mc.value("threads", 0),
                    st.value("cpu_side", true) ? "once" : "not run (--no-cpu)", r.value("started", "?"));
  md << "GPU shadow: the GPU time of the method's stages (stage by stage in brackets); frame: every stage of the frame "
        "(camera pass, method, compose, resolve); first frame: the same for the warm-up frame, which also pays "
        "what later frames of the same scene and light reuse (maps, slices, a precompute; † a method that slow is "
        "timed by one run); CPU: the same method on this machine's cores at the same settings "
        "(* at half the width and height: it would take over 10 s); CPU/GPU: the ratio of the shadow times per "
        "pixel.\n\n";
  for (const json& s : r.at("scenes")) {
    md << "**" << s.value("name", "?") << "** (" << s.value("triangles", 0) << " triangles)\n\n"
       << "| method | GPU shadow | GPU frame | GPU first frame | CPU shadow | CPU/GPU | shadow rays/s (GPU) |\n"
       << "|---|---:|---:|---:|---:|---:|---:|\n";
    for (const json& m : s.at("methods")) {
      md << "| `" << m.value("method", "?") << "` | ";
      if (!m.value("ok", false)) {
        md << "failed: " << m.value("error", "") << " | | | | | |\n";
        continue;
      }
      const json& g = m["gpu"];
      const json c = m.value("cpu", json::object());
      std::string stages;
      for (auto it = g["stages_ms"].begin(); it != g["stages_ms"].end(); ++it) {
        if (it.key() == "total" || it.key() == "readback" || it.key() == "camera_pass" || it.key() == "resolve" ||
            it.key() == "compose")
          continue;
        stages += (stages.empty() ? "" : ", ") + it.key() + " " + format_significant(it.value().get<double>(), 3);
      }
      md << format_significant(g.value("shadow_ms", 0.0), 3) << " ms (" << stages << ") | "
         << format_significant(g.value("frame_ms", 0.0), 3) << " ms | "
         << (g.contains("first_frame_ms") && g["first_frame_ms"].is_object()
                 ? format_significant(g["first_frame_ms"].value("total", 0.0), 3) + " ms" +
                       (g.value("runs", 0) == 1 && st.value("runs", 0) > 1 ? "†" : "")
                 : "—")
         << " | "
         << (c.empty() ? "—"
                       : format_significant(c.value("shadow_ms", 0.0), 3) + " ms" +
                             (c.value("reduced", false) ? "*" : ""))
         << " | "
         << (m.contains("cpu_over_gpu") ? format_significant(m["cpu_over_gpu"].get<double>(), 3) + "×" : "—")
         << " | "
         << (g.contains("rays_per_s") ? format_significant(g["rays_per_s"].get<double>() / 1e6, 3) + " M" : "—")
         << " |\n";
    }
    md << "\n" << kernel_table(s.at("methods"));
  }
  return md.str();
}

}  // namespace penumbra
