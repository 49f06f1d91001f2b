#include "penumbra/eval/bench.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <fmt/format.h>

#include "penumbra/core/error.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/eval/comparison.h"
#include "penumbra/eval/report_util.h"

namespace penumbra {

namespace fs = std::filesystem;
using nlohmann::json;

BenchSuite bench_suite(const std::string& name, const fs::path& scenes_dir) {
  BenchSuite s;
  s.name = name;
  for (const char* scene : {"bunny", "contact", "furball", "knot", "plant"})
    s.scenes.push_back(scenes_dir / (std::string(scene) + ".json"));
  if (name == "quick") {
    s.resolution = 128;
    s.light_samples = 16;
    s.runs = 3;
    s.warmup_runs = 1;
  } else if (name == "full") {
    s.resolution = 512;
    s.light_samples = 256;
    s.runs = 5;
    s.warmup_runs = 1;
  } else {
    throw Error("--suite {}: unknown suite (quick, full)", name);
  }
  return s;
}

json run_bench(const BenchOptions& o) {
  Timer wall;
  const BenchSuite& suite = o.suite;
  if (suite.scenes.empty()) throw Error("bench: no scenes");
  const std::string started = local_time_iso();
  // The reference first: it is what every other row is measured against.
  std::vector<std::string> methods = {"reference"};
  for (const auto& m : o.methods)
    if (m != "reference") methods.push_back(m);

  // Every scene's setup before any render: a missing scene or bad setting fails at once.
  std::vector<RunSetup> setups;
  for (const fs::path& f : suite.scenes) {
    RunSetup setup = RunSetup::from_file(f);
    setup.apply("resolution", std::to_string(suite.resolution));
    setup.apply("spp", std::to_string(suite.light_samples));
    for (const std::string& kv : o.params) setup.apply(kv);
    setup.check_plain_params(methods);
    setups.push_back(std::move(setup));
  }
  CompareOptions co;
  co.methods = methods;
  co.ground_truth = false;
  co.runs = suite.runs;
  co.warmup_runs = suite.warmup_runs;
  co.keep_images = false;
  uint64_t total = 0;
  for (const auto& s : setups) total += comparison_progress_units(s, co);
  Progress bar("bench", total, o.progress);
  co.progress_bar = &bar;

  json scenes = json::array();
  for (size_t i = 0; i < setups.size(); ++i) {
    Comparison c;
    try {
      c = run_comparison(setups[i], co);
    } catch (const std::exception& e) {
      // A scene that cannot be loaded is reported; the other scenes still run.
      json ms = json::array();
      for (const auto& m : methods) ms.push_back({{"method", m}, {"ok", false}, {"error", e.what()}});
      scenes.push_back({{"scene", setups[i].scene_path.string()},
                        {"name", setups[i].scene_path.stem().string()},
                        {"error", e.what()},
                        {"methods", ms}});
      continue;
    }
    json ms = json::array();
    for (const MethodRun& r : c.runs) {
      json m = {{"method", r.method}, {"ok", r.ok}};
      if (!r.ok) {
        m["error"] = r.error;
      } else {
        m["shadow_ms"] = r.times.shadow_ms;
        m["total_ms"] = r.times.total_ms;
        m["camera_pass_ms"] = r.times.camera_pass_ms;
        m["run_shadow_ms"] = r.run_shadow_ms;
        m["speedup"] = json_number(r.speedup);
        m["light_samples"] = r.light_samples;
        m["rays_traced"] = r.stats.rays_traced;
        m["memory_bytes"] = r.stats.memory_bytes;
        json phases = json::object();
        for (const auto& [n, t] : r.stats.phases_ms) phases[n] = t;
        m["phases_ms"] = phases;
      }
      ms.push_back(m);
    }
    scenes.push_back({{"scene", c.scene},
                      {"name", fs::path(c.scene).stem().string()},
                      {"resolution", {c.width, c.height}},
                      {"triangles", c.triangles},
                      {"speedup_basis", c.speedup_basis},
                      {"reference_shadow_ms", c.speedup_basis_ms},
                      {"methods", ms}});
  }
  bar.finish();
  return {{"suite", suite.name},
          {"settings",
           {{"resolution", suite.resolution},
            {"spp", suite.light_samples},
            {"runs", suite.runs},
            {"warmup_runs", suite.warmup_runs},
            {"params", o.params}}},
          {"timing",
           "shadow_ms = total - camera pass - compose (the method's prepare + evaluate), median of the runs; "
           "speedup = reference's shadow_ms / the method's, both measured in this run"},
          {"methods", methods},
          {"machine", machine_json()},
          {"started", started},
          {"wall_ms", wall.elapsed_ms()},
          {"command", o.command},
          {"scenes", scenes}};
}

std::string bench_markdown(const json& r) {
  std::ostringstream md;
  const json& st = r.at("settings");
  const json& mc = r.at("machine");
  md << fmt::format("Suite `{}`: {}×{} pixels, {} light samples, median of {} runs after {} warm-up; {}, {} threads, {}, "
                    "{}; {}.\n\n",
                    r.value("suite", "?"), st.value("resolution", 0), st.value("resolution", 0), st.value("spp", 0),
                    st.value("runs", 0), st.value("warmup_runs", 0), mc.value("cpu", "?"), mc.value("threads", 0),
                    mc.value("compiler", "?"), mc.value("build", "?"), r.value("started", "?"));
  md << "Each cell: the method's shadow time (total − camera pass − compose) in ms, and in brackets its "
        "speed-up over `reference` (Embree ray tracing at the same light samples) on that scene.\n\n";
  md << "| method |";
  for (const json& s : r.at("scenes")) md << " " << s.value("name", "?") << " |";
  md << "\n|---|";
  for (size_t i = 0; i < r.at("scenes").size(); ++i) md << "---:|";
  md << "\n";
  for (const json& mname : r.at("methods")) {
    std::string name = mname.get<std::string>();
    md << "| `" << name << "` |";
    for (const json& s : r.at("scenes")) {
      std::string cell = "—";
      for (const json& m : s.at("methods")) {
        if (m.value("method", "") != name) continue;
        if (!m.value("ok", false)) {
          cell = "failed";
        } else {
          cell = format_significant(m.value("shadow_ms", 0.0), 3) + " ms";
          if (m.contains("speedup") && m["speedup"].is_number())
            cell += " (" + format_significant(m["speedup"].get<double>(), 3) + "×)";
        }
      }
      md << " " << cell << " |";
    }
    md << "\n";
  }
  // Failures, with their messages, below the table.
  for (const json& s : r.at("scenes")) {
    if (s.contains("error")) {
      md << "\n- scene " << s.value("name", "?") << " failed: " << s.value("error", "") << "\n";
      continue;
    }
    for (const json& m : s.at("methods"))
      if (!m.value("ok", false))
        md << "\n- `" << m.value("method", "?") << "` failed on " << s.value("name", "?") << ": "
           << m.value("error", "") << "\n";
  }
  if (!r.value("command", "").empty()) md << "\nCommand: `" << r.value("command", "") << "`\n";
  return md.str();
}

}  // namespace penumbra
