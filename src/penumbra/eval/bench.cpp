#include "penumbra/eval/bench.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>

#include <fmt/format.h>

#include "penumbra/core/error.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/timer.h"
#include "penumbra/eval/comparison.h"
#include "penumbra/eval/reference_cache.h"
#include "penumbra/eval/report_util.h"
#include "penumbra/render/sequence_renderer.h"
#include "penumbra/scene/animation.h"

namespace penumbra {

namespace fs = std::filesystem;
using nlohmann::json;

const std::vector<PerfTarget>& perf_targets() {
  using K = PerfTarget::Kind;
  static const std::vector<PerfTarget> targets = [] {
    std::vector<PerfTarget> t;
    for (const char* scene : {"bunny", "plant"}) {
      // sintorn2008's point: its cost barely grows with the light samples, so at high counts it wins.
      t.push_back({"afsm", scene, 1024, 0, K::kSpeedup, "shadow_ms", 2.0, {}});
      t.push_back({"afsm", scene, 256, 0, K::kSpeedup, "shadow_ms", 1.0, {}});
      for (const char* m : {"mlsm", "mtsm", "coherent-rt", "multi-view-sm"})
        t.push_back({m, scene, 256, 0, K::kSpeedup, "shadow_ms", 1.0, {}});
    }
    // lam: one render of a 512^2 frame with 64 light samples times both the precompute
    // (prepare) and the display (evaluate), the paper's display: the lookup alone, no point traced
    // (lam.md "Points the LDI does not resolve").
    t.push_back({"lam", "bunny", 64, 512, K::kTime, "phase:display", 5.0, {"lam.unresolved=umbra"}});
    t.push_back({"lam", "bunny", 64, 512, K::kTime, "phase:precompute", 500.0, {"lam.unresolved=umbra"}});
    // 60 fps: the whole 512^2 frame, camera pass and compose included.
    for (const char* m : {"hard", "shadow-map", "pcss", "single-sample", "occlusion-textures"})
      t.push_back({m, "bunny", 256, 512, K::kTime, "total_ms", 16.0, {}});
    return t;
  }();
  return targets;
}

namespace {

int target_resolution(const PerfTarget& t, int suite_resolution) {
  return t.resolution > 0 ? t.resolution : suite_resolution;
}

std::string measure_name(const std::string& measure) {
  if (measure == "total_ms") return "whole frame";
  if (measure.rfind("phase:", 0) == 0) return measure.substr(6);
  return measure;
}

}  // namespace

std::string perf_target_label(const PerfTarget& t, int suite_resolution) {
  const int res = target_resolution(t, suite_resolution);
  std::string params;
  for (const auto& p : t.params) params += ", " + p;
  if (t.kind == PerfTarget::Kind::kSpeedup)
    return fmt::format("{}, {} spp, {} {}²{}: speed-up over reference ≥ {}×", t.method, t.light_samples, t.scene, res,
                       params, fmt::format("{:g}", t.goal));
  return fmt::format("{}, {} spp, {} {}²{}: {} < {} ms", t.method, t.light_samples, t.scene, res, params,
                     measure_name(t.measure), fmt::format("{:g}", t.goal));
}

BenchSuite bench_suite(const std::string& name, const fs::path& scenes_dir) {
  BenchSuite s;
  s.name = name;
  if (name == "perf") {
    s.scenes = {scenes_dir / "bunny.json", scenes_dir / "plant.json"};
    s.resolution = 256;
    s.light_samples = 256;
    s.runs = 5;
    s.warmup_runs = 1;
    s.targets = perf_targets();
    return s;
  }
  if (name == "walk") {
    s.scenes = {scenes_dir / "bunny-walk.json", scenes_dir / "plant-light.json", scenes_dir / "furball-spin.json"};
    s.resolution = 256;
    s.light_samples = 256;
    s.sequence_frames = 8;
    s.runs = 1;
    s.warmup_runs = 0;
    // The paper's reuse: its display alone per frame, no point traced (lam.md "Points the LDI does
    // not resolve"); run beside `lam` as shipped.
    PerfTarget lam_walk;
    lam_walk.method = "lam:unresolved=umbra";
    lam_walk.scene = "bunny-walk";
    lam_walk.light_samples = 256;
    lam_walk.goal = 50;
    s.sequence_targets = {lam_walk};
    return s;
  }
  if (name == "gpu") {
    // Issue 28 part 7 / issue 31: the GPU methods against their CPU versions, at a GPU frame's size.
    s.scenes = {scenes_dir / "bunny.json", scenes_dir / "plant.json"};
    s.resolution = 1920;
    s.height = 1080;
    s.light_samples = 256;
    s.runs = 5;
    s.warmup_runs = 1;
    s.devices = true;
    return s;
  }
  if (name == "wide") {
    // Issues 32 and 34: wide scenes beside the single object they are measured against (the
    // bunny): the 25-tree forest (1.48 M triangles), a street of boxes with lamps, cars and trees,
    // and the 100-tree forest (5.9 M, mostly instances), at issue 34's settings, each method's
    // error against the ground truth (1024 light samples, cached) beside its time.
    s.scenes = {scenes_dir / "bunny.json", scenes_dir / "forest.json", scenes_dir / "street.json",
                scenes_dir / "forest-100.json"};
    s.resolution = 256;
    s.light_samples = 256;
    s.reference_spp = 1024;
    s.runs = 1;
    s.warmup_runs = 0;
    // Where the error lives: the ground, and the casters (the bunny; the crowns' leaves).
    s.object_groups = {{"bunny", {"ground", "bunny"}},
                       {"forest", {"ground", "*.leaves"}},
                       {"forest-100", {"ground", "*.leaves"}}};
    return s;
  }
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
    throw Error("--suite {}: unknown suite (quick, full, perf, walk, wide, gpu)", name);
  }
  return s;
}

json bench_document(const BenchOptions& o, json settings, const std::string& timing,
                    const std::vector<std::string>& methods, const std::string& started, double wall_ms, json scenes) {
  settings["params"] = o.params;
  return {{"suite", o.suite.name},
          {"settings", std::move(settings)},
          {"timing", timing},
          {"methods", methods},
          {"machine", machine_json()},
          {"started", started},
          {"wall_ms", wall_ms},
          {"command", o.command},
          {"scenes", std::move(scenes)}};
}

namespace {

json scene_entry(const Comparison& c, const std::string& name) {
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
      m["run_total_ms"] = r.run_total_ms;
      m["speedup"] = json_number(r.speedup);
      if (std::isfinite(r.v.mae)) m["v_mae"] = r.v.mae;
      // The error over each of the scene's object groups (BenchSuite::object_groups), by pattern.
      json by_object = json::object();
      for (size_t g = 0; g < r.v_objects.size() && g < c.object_groups.size(); ++g)
        by_object[c.object_groups[g].pattern] = {{"v_mae", json_number(r.v_objects[g].mae)},
                                                 {"v_mean_signed", json_number(r.v_objects[g].mean_signed)}};
      if (!by_object.empty()) m["v_objects"] = by_object;
      m["light_samples"] = r.light_samples;
      m["rays_traced"] = r.stats.rays_traced;
      m["memory_bytes"] = r.stats.memory_bytes;
      json phases = json::object();
      for (const auto& [n, t] : r.stats.phases_ms) phases[n] = t;
      m["phases_ms"] = phases;
    }
    ms.push_back(m);
  }
  json out = {{"scene", c.scene},
              {"name", name},
              {"resolution", {c.width, c.height}},
              {"triangles", c.triangles},
              {"load_ms", c.load_ms},
              // The most memory the process has held by the end of this scene's runs.
              {"peak_rss_bytes", peak_rss_bytes()},
              {"speedup_basis", c.speedup_basis},
              {"reference_shadow_ms", c.speedup_basis_ms},
              {"methods", ms}};
  if (!c.object_groups.empty()) out["object_groups"] = object_groups_json(c.object_groups);
  // The Embree scene every method's renderer builds alike: the first successful run's.
  for (const MethodRun& r : c.runs)
    if (r.ok && !r.tracer.is_null()) {
      out["embree"] = r.tracer;
      break;
    }
  return out;
}

// The value of a time target in every timed run of `r`: its whole frame or one phase.
std::vector<double> measured_runs(const MethodRun& r, const std::string& measure) {
  if (measure == "total_ms") return r.run_total_ms;
  if (measure == "shadow_ms") return r.run_shadow_ms;
  std::vector<double> v;
  const std::string phase = measure.rfind("phase:", 0) == 0 ? measure.substr(6) : measure;
  for (const auto& phases : r.run_phases_ms) {
    double t = std::numeric_limits<double>::quiet_NaN();
    for (const auto& [n, ms] : phases)
      if (n == phase) t = std::isnan(t) ? ms : t + ms;
    v.push_back(t);
  }
  return v;
}

// The target suite: the targets grouped by scene and settings, each group one comparison of
// its methods and `reference`, every run of each interleaved.
json run_targets(const BenchOptions& o, const std::string& started, const Timer& wall) {
  const BenchSuite& suite = o.suite;
  struct Group {
    std::string scene_name, label;
    fs::path scene;
    int light_samples = 0, resolution = 0;
    std::vector<std::string> params, methods;
    std::vector<size_t> targets;
    RunSetup setup;
  };
  std::vector<Group> groups;
  std::vector<PerfTarget> targets;
  for (const PerfTarget& t : suite.targets) {
    if (!o.methods.empty() && std::find(o.methods.begin(), o.methods.end(), t.method) == o.methods.end()) continue;
    auto file = std::find_if(suite.scenes.begin(), suite.scenes.end(),
                             [&](const fs::path& f) { return f.stem().string() == t.scene; });
    if (file == suite.scenes.end()) continue;  // its scene is not in this run (--scenes)
    const int res = target_resolution(t, suite.resolution);
    auto g = std::find_if(groups.begin(), groups.end(), [&](const Group& g) {
      return g.scene_name == t.scene && g.light_samples == t.light_samples && g.resolution == res &&
             g.params == t.params;
    });
    if (g == groups.end()) {
      Group ng;
      ng.scene_name = t.scene;
      ng.scene = *file;
      ng.light_samples = t.light_samples;
      ng.resolution = res;
      ng.params = t.params;
      ng.label = fmt::format("{} {}² {} spp", t.scene, res, t.light_samples);
      groups.push_back(std::move(ng));
      g = groups.end() - 1;
    }
    if (t.kind == PerfTarget::Kind::kSpeedup && std::find(g->methods.begin(), g->methods.end(), "reference") == g->methods.end())
      g->methods.insert(g->methods.begin(), "reference");
    if (std::find(g->methods.begin(), g->methods.end(), t.method) == g->methods.end()) g->methods.push_back(t.method);
    g->targets.push_back(targets.size());
    targets.push_back(t);
  }
  if (targets.empty()) throw Error("bench: none of the suite's targets is left after --methods and --scenes (targets on {})",
                [&] {
                  std::string names;
                  for (const PerfTarget& t : suite.targets)
                    if (names.find(t.scene) == std::string::npos) names += (names.empty() ? "" : ", ") + t.scene;
                  return names;
                }());

  // Every group's setup before any render: a missing scene or bad setting fails at once.
  for (Group& g : groups) {
    g.setup = RunSetup::from_file(g.scene);
    g.setup.apply("resolution", std::to_string(g.resolution));
    g.setup.apply("spp", std::to_string(g.light_samples));
    g.setup.device = o.device;
    for (const std::string& kv : o.params) g.setup.apply(kv);
    for (const std::string& kv : g.params) g.setup.apply(kv);
    g.setup.check_plain_params(g.methods);
  }
  CompareOptions co;
  co.ground_truth = false;
  co.runs = suite.runs;
  co.warmup_runs = suite.warmup_runs;
  co.keep_images = false;
  co.interleave = true;
  uint64_t total = 0;
  for (const Group& g : groups) {
    co.methods = g.methods;
    total += comparison_progress_units(g.setup, co);
  }
  Progress bar("bench", total, o.progress);
  co.progress_bar = &bar;

  json scenes = json::array(), results = json::array();
  std::vector<json> target_results(targets.size());
  for (const Group& g : groups) {
    co.methods = g.methods;
    Comparison c;
    std::string group_error;
    try {
      c = run_comparison(g.setup, co);
      scenes.push_back(scene_entry(c, g.label));
    } catch (const Interrupted&) {
      throw;  // Ctrl-C ends the run, whatever this step would do with an error
    } catch (const std::exception& e) {
      group_error = e.what();
      scenes.push_back({{"scene", g.scene.string()}, {"name", g.label}, {"error", group_error}, {"methods", json::array()}});
    }
    for (size_t ti : g.targets) {
      const PerfTarget& t = targets[ti];
      json tr = {{"target", perf_target_label(t, suite.resolution)},
                 {"method", t.method},
                 {"scene", t.scene},
                 {"group", g.label},
                 {"light_samples", t.light_samples},
                 {"resolution", g.resolution},
                 {"kind", t.kind == PerfTarget::Kind::kSpeedup ? "speedup" : "time"},
                 {"measure", t.measure},
                 {"goal", t.goal},
                 {"params", t.params}};
      const MethodRun* run = nullptr;
      const MethodRun* ref = nullptr;
      for (const MethodRun& r : c.runs) {
        if (r.method == t.method) run = &r;
        if (r.method == "reference") ref = &r;
      }
      std::string error = group_error;
      if (error.empty() && (!run || !run->ok)) error = run ? run->error : "not run";
      if (error.empty() && t.kind == PerfTarget::Kind::kSpeedup && (!ref || !ref->ok))
        error = "reference failed: " + (ref ? ref->error : std::string("not run"));
      if (!error.empty()) {
        tr["value"] = nullptr;
        tr["result"] = "FAILED";
        tr["error"] = error;
      } else if (t.kind == PerfTarget::Kind::kSpeedup) {
        // Medians of runs taken side by side (interleaved): reference's / the method's.
        tr["value"] = json_number(run->speedup);
        tr["method_ms"] = run->times.shadow_ms;
        tr["reference_ms"] = ref->times.shadow_ms;
        tr["run_method_ms"] = run->run_shadow_ms;
        tr["run_reference_ms"] = ref->run_shadow_ms;
        tr["result"] = run->speedup >= t.goal ? "PASS" : "MISS";
      } else {
        std::vector<double> v = measured_runs(*run, t.measure);
        const bool measured = !v.empty() && std::none_of(v.begin(), v.end(), [](double x) { return std::isnan(x); });
        if (!measured) {
          tr["value"] = nullptr;
          tr["result"] = "FAILED";
          tr["error"] = fmt::format("{} reports no {}", t.method, measure_name(t.measure));
        } else {
          const double med = median_of(v);
          tr["value"] = med;
          tr["run_values"] = v;
          tr["result"] = med < t.goal ? "PASS" : "MISS";
        }
      }
      target_results[ti] = tr;
    }
  }
  bar.finish();
  for (json& tr : target_results) results.push_back(std::move(tr));
  std::vector<std::string> methods = {"reference"};
  for (const PerfTarget& t : targets)
    if (std::find(methods.begin(), methods.end(), t.method) == methods.end()) methods.push_back(t.method);
  json out = bench_document(
      o,
      {{"resolution", suite.resolution},
       {"spp", suite.light_samples},
       {"runs", suite.runs},
       {"warmup_runs", suite.warmup_runs},
       {"interleaved", true}},
      "speed-up targets: reference's median shadow_ms / the method's, their runs interleaved (method, "
      "reference, method, ...) in one process; time targets: the median over the runs of the whole frame "
      "(total_ms, camera pass included) or of one phase",
      methods, started, wall.elapsed_ms(), scenes);
  out["targets"] = results;
  return out;
}

// `reference` first (what every other row is measured against), then --methods.
std::vector<std::string> methods_with_reference(const BenchOptions& o) {
  std::vector<std::string> methods = {"reference"};
  for (const auto& m : o.methods)
    if (m != "reference") methods.push_back(m);
  return methods;
}

// The setup of every scene of the suite at its resolution and light samples, with -p settings.
std::vector<RunSetup> suite_setups(const BenchOptions& o, const std::vector<std::string>& methods) {
  std::vector<RunSetup> setups;
  for (const fs::path& f : o.suite.scenes) {
    RunSetup setup = RunSetup::from_file(f);
    setup.apply("resolution", std::to_string(o.suite.resolution));
    setup.apply("spp", std::to_string(o.suite.light_samples));
    if (o.suite.reference_spp > 0) setup.reference_samples = o.suite.reference_spp;
    setup.device = o.device;
    for (const std::string& kv : o.params) setup.apply(kv);
    setup.check_plain_params(methods);
    setups.push_back(std::move(setup));
  }
  return setups;
}

// The walk suite: each scene's frames rendered by every method in turn, frame by frame.
json run_sequences(const BenchOptions& o, const std::vector<std::string>& methods, const std::string& started,
                   const Timer& wall) {
  const BenchSuite& suite = o.suite;
  // Every scene's setup before any render: a missing scene or bad setting fails at once.
  const std::vector<RunSetup> setups = suite_setups(o, methods);
  json scenes = json::array();
  Progress bar("bench", setups.size() * methods.size() * suite.sequence_frames, o.progress);
  for (const RunSetup& setup : setups) {
    const std::string name = setup.scene_path.stem().string();
    const Scene scene = setup.load();
    if (!scene.animation) throw Error("bench: {}: the scene has no \"animation\" block", setup.scene_path.string());
    const int frames = std::min(suite.sequence_frames, scene.animation->frames);
    struct Sequence {
      std::unique_ptr<SequenceRenderer> renderer;
      std::string error;
      std::vector<double> shadow_ms, total_ms;
      int moved_frames = 0, refit_frames = 0;
    };
    std::vector<Sequence> seqs(methods.size());
    for (size_t k = 0; k < methods.size(); ++k) {
      const MethodSpec spec = parse_method_spec(methods[k]);
      RenderSettings settings;
      settings.method = spec.name;
      settings.params = setup.overrides_for(spec);
      settings.light_samples = setup.light_samples;
      settings.seed = setup.seed;
      seqs[k].renderer = std::make_unique<SequenceRenderer>(scene, settings);
    }
    for (int f = 0; f < frames; ++f)
      for (size_t k = 0; k < methods.size(); ++k) {  // side by side, frame by frame
        bar.set_label(fmt::format("bench {} frame {}: {}", name, f, methods[k]));
        Sequence& q = seqs[k];
        if (q.error.empty()) {
          try {
            const SequenceRenderer::Frame frame = q.renderer->render(f);
            const RenderResult& r = frame.result;
            q.shadow_ms.push_back(shadow_time_ms(r));
            // The frame's whole cost includes moving objects in the Embree scene.
            q.total_ms.push_back(r.total_ms + frame.geometry_update_ms);
            q.moved_frames += frame.moved_objects > 0;
            q.refit_frames += frame.refit;
          } catch (const Interrupted&) {
            throw;
          } catch (const std::exception& e) {
            q.error = e.what();
            q.renderer.reset();
          }
        }
        bar.add(1);
      }
    // A method's cost per frame once its structures exist: the median over frames 1 .. N-1.
    auto steady = [](const std::vector<double>& v) {
      return median_of(v.size() > 1 ? std::vector<double>(v.begin() + 1, v.end()) : v);
    };
    const double reference_ms = seqs[0].error.empty() ? steady(seqs[0].shadow_ms) : 0.0;
    json ms = json::array();
    for (size_t k = 0; k < methods.size(); ++k) {
      const Sequence& q = seqs[k];
      json m = {{"method", methods[k]}, {"ok", q.error.empty()}};
      if (!q.error.empty()) {
        m["error"] = q.error;
      } else {
        const double per_frame = steady(q.shadow_ms);
        m["shadow_ms"] = per_frame;
        m["total_ms"] = steady(q.total_ms);
        m["first_frame_shadow_ms"] = q.shadow_ms.front();
        m["run_shadow_ms"] = q.shadow_ms;  // every frame's
        m["run_total_ms"] = q.total_ms;
        m["moved_frames"] = q.moved_frames;  // frames where objects moved
        m["refit_frames"] = q.refit_frames;  // ... and were refit in the Embree scene, not rebuilt
        m["speedup"] = json_number(reference_ms > 0 && per_frame > 0 ? reference_ms / per_frame
                                                                    : std::numeric_limits<double>::quiet_NaN());
      }
      ms.push_back(m);
    }
    scenes.push_back({{"scene", setup.scene_path.string()},
                      {"name", name},
                      {"frames", frames},
                      {"resolution", {scene.camera.width, scene.camera.height}},
                      {"triangles", scene.triangle_count()},
                      {"speedup_basis", "reference"},
                      {"reference_shadow_ms", reference_ms},
                      {"methods", ms}});
  }
  bar.finish();
  json targets = json::array();
  for (const PerfTarget& t : suite.sequence_targets) {
    json entry = {{"target", fmt::format("{}, {} spp, {} {}², per frame once its maps exist: speed-up over reference "
                                         "≥ {}×",
                                         t.method, suite.light_samples, t.scene, suite.resolution, t.goal)},
                  {"kind", "speedup"},
                  {"method", t.method},
                  {"scene", t.scene},
                  {"goal", t.goal}};
    for (const json& sc : scenes)
      if (sc.value("name", "") == t.scene)
        for (const json& m : sc.at("methods"))
          if (m.value("method", "") == t.method && m.value("ok", false) && m["speedup"].is_number()) {
            const double v = m["speedup"].get<double>();
            entry["value"] = v;
            entry["result"] = v >= t.goal ? "PASS" : "MISS";
          }
    if (!entry.contains("result")) continue;  // its method or scene is not in this run
    targets.push_back(entry);
  }
  json out = bench_document(
      o,
      {{"resolution", suite.resolution},
       {"spp", suite.light_samples},
       {"frames", suite.sequence_frames},
       {"runs", 1},
       {"warmup_runs", 0}},
      "per frame: shadow_ms = total - camera pass - compose of each frame, the median over frames 1..N-1 "
      "(the first frame, which builds the light-space structures, is first_frame_shadow_ms); every "
      "method renders the frames one after another keeping what stays valid (render/sequence_renderer.h); "
      "speedup = reference's per-frame shadow_ms / the method's, the methods interleaved frame by frame",
      methods, started, wall.elapsed_ms(), scenes);
  if (!targets.empty()) out["targets"] = targets;
  return out;
}

}  // namespace

json run_bench(const BenchOptions& o) {
  Timer wall;
  const BenchSuite& suite = o.suite;
  if (suite.scenes.empty()) throw Error("bench: no scenes");
  const std::string started = local_time_iso();
  if (suite.devices) return run_gpu_suite(o);
  if (!suite.targets.empty()) return run_targets(o, started, wall);
  std::vector<std::string> methods = methods_with_reference(o);
  if (suite.sequence_frames > 0) {
    // A target that names a variant ("lam:unresolved=umbra") runs beside its method when that runs.
    for (const PerfTarget& t : suite.sequence_targets)
      if (std::find(methods.begin(), methods.end(), parse_method_spec(t.method).name) != methods.end() &&
          std::find(methods.begin(), methods.end(), t.method) == methods.end())
        methods.push_back(t.method);
    return run_sequences(o, methods, started, wall);
  }

  // Every scene's setup before any render: a missing scene or bad setting fails at once.
  const std::vector<RunSetup> setups = suite_setups(o, methods);
  CompareOptions co;
  co.methods = methods;
  co.ground_truth = suite.reference_spp > 0;
  if (co.ground_truth) co.cache_dir = default_cache_dir();
  co.equal_quality = false;
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
      co.objects.clear();
      if (co.ground_truth)
        for (const auto& [stem, patterns] : suite.object_groups)
          if (setups[i].scene_path.stem().string() == stem) co.objects = patterns;
      c = run_comparison(setups[i], co);
    } catch (const Interrupted&) {
      throw;  // Ctrl-C ends the run, whatever this step would do with an error
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
    scenes.push_back(scene_entry(c, fs::path(c.scene).stem().string()));
  }
  bar.finish();
  return bench_document(o,
                        {{"resolution", suite.resolution},
                         {"spp", suite.light_samples},
                         {"runs", suite.runs},
                         {"warmup_runs", suite.warmup_runs},
                         {"reference_spp", suite.reference_spp}},
                        "shadow_ms = total - camera pass - compose (the method's prepare + evaluate), median of the "
                        "runs; speedup = reference's shadow_ms / the method's, both measured in this run; v_mae "
                        "(with reference_spp > 0) = mean |dV| against the ground truth at reference_spp",
                        methods, started, wall.elapsed_ms(), scenes);
}

std::string bench_markdown(const json& r) {
  if (r.contains("device")) return gpu_bench_markdown(r);
  std::ostringstream md;
  const json& st = r.at("settings");
  const json& mc = r.at("machine");
  // The build, and whether the heap was on 2 MiB pages (core/huge_pages.h): times of a wide
  // scene differ by about a fifth between the two.
  const std::string build =
      mc.value("build", "?") + (mc.value("huge_pages", false) ? ", heap on 2 MiB pages" : ", heap on 4 KiB pages");
  const bool sequences = st.contains("frames");
  if (sequences) {
    md << fmt::format("Suite `{}`: {}×{} pixels, {} light samples, frames 0–{} of each animated scene rendered one "
                      "after another (the light-space structures kept while only the camera or a light moves), the "
                      "methods interleaved frame by frame; {}, {} threads, {}, {}; {}.\n\n",
                      r.value("suite", "?"), st.value("resolution", 0), st.value("resolution", 0), st.value("spp", 0),
                      st.value("frames", 0) - 1, mc.value("cpu", "?"), mc.value("threads", 0),
                      mc.value("compiler", "?"), build, r.value("started", "?"));
  } else if (r.contains("targets")) {
    md << fmt::format("Suite `{}`: the speed-up targets at {}×{} pixels, the time targets at their own size; light "
                      "samples per target; median of {} runs after {} warm-up, every method's runs interleaved with "
                      "the others' of its scene; {}, {} threads, {}, {}; {}.\n\n",
                      r.value("suite", "?"), st.value("resolution", 0), st.value("resolution", 0), st.value("runs", 0),
                      st.value("warmup_runs", 0), mc.value("cpu", "?"), mc.value("threads", 0),
                      mc.value("compiler", "?"), build, r.value("started", "?"));
  } else {
    md << fmt::format("Suite `{}`: {}×{} pixels, {} light samples, median of {} runs after {} warm-up; {}, {} threads, "
                      "{}, {}; {}.\n\n",
                      r.value("suite", "?"), st.value("resolution", 0), st.value("resolution", 0), st.value("spp", 0),
                      st.value("runs", 0), st.value("warmup_runs", 0), mc.value("cpu", "?"), mc.value("threads", 0),
                      mc.value("compiler", "?"), build, r.value("started", "?"));
  }
  if (r.contains("targets")) {
    md << (sequences ? "Targets (issue 18): per-frame speed-ups, reference's median shadow time per frame / the "
                       "method's, once the method's light-space structures exist.\n\n"
                     : "Targets (issue 14): speed-ups are reference's median shadow time / the method's, their runs "
                       "interleaved in this process; times are medians of the whole frame (camera pass included) or "
                       "of one phase.\n\n")
       << "| target | measured | result |\n|---|---:|---|\n";
    int pass = 0, all = 0;
    for (const json& t : r.at("targets")) {
      std::string value = "—";
      if (t.contains("value") && t["value"].is_number()) {
        double v = t["value"].get<double>();
        value = t.value("kind", "") == "speedup" ? format_significant(v, 3) + "×" : format_significant(v, 3) + " ms";
      }
      std::string result = t.value("result", "?");
      if (t.contains("error")) result += ": " + t.value("error", "");
      md << "| " << t.value("target", "?") << " | " << value << " | **" << result << "** |\n";
      pass += t.value("result", "") == "PASS" ? 1 : 0;
      ++all;
    }
    md << "\n" << pass << " of " << all << " targets met.\n\n";
  }
  md << (sequences ? "Each cell: the method's shadow time per frame (total − camera pass − compose; the median "
                     "over frames 1 and on) in ms, and in brackets its speed-up over `reference` per frame on that "
                     "scene; bench-results.json also has each method's first frame and every frame's time.\n\n"
                   : "Each cell: the method's shadow time (total − camera pass − compose) in ms, and in brackets its "
                     "speed-up over `reference` (Embree ray tracing at the same light samples) on that scene.\n\n");
  if (st.value("reference_spp", 0) > 0)
    md << "Error: the method's mean |dV| against the ground truth (`reference` at " << st.value("reference_spp", 0)
       << " light samples).\n\n";
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
          if (m.contains("v_mae")) cell += ", error " + format_significant(m["v_mae"].get<double>(), 2);
        }
      }
      md << " " << cell << " |";
    }
    md << "\n";
  }
  // The wide-scene line (issue 34): each later scene against the first (the wide suite's
  // bunny), per method: its mean |dV| and its time as multiples of its own on the first scene,
  // and whether its error exceeds `hard`'s on that scene.
  const json& scene_list = r.at("scenes");
  auto find_method = [](const json& scene, const std::string& name) -> const json* {
    if (!scene.contains("methods")) return nullptr;
    for (const json& m : scene.at("methods"))
      if (m.value("method", "") == name && m.value("ok", false)) return &m;
    return nullptr;
  };
  const bool wide_line = scene_list.size() > 1 && st.value("reference_spp", 0) > 0;
  if (wide_line) {
    const std::string base = scene_list[0].value("name", "?");
    md << "\nAgainst `" << base << "`: each method's error (mean |dV|) and shadow time on each scene as multiples of its own "
       << "on `" << base << "`; **worse than hard** where its mean |dV| exceeds `hard`'s on that scene.\n\n| method |";
    for (size_t i = 1; i < scene_list.size(); ++i) md << " " << scene_list[i].value("name", "?") << " |";
    md << "\n|---|";
    for (size_t i = 1; i < scene_list.size(); ++i) md << "---|";
    md << "\n";
    for (const json& mname : r.at("methods")) {
      const std::string name = mname.get<std::string>();
      const json* b = find_method(scene_list[0], name);
      md << "| `" << name << "` |";
      for (size_t i = 1; i < scene_list.size(); ++i) {
        const json* m = find_method(scene_list[i], name);
        const json* hard = find_method(scene_list[i], "hard");
        std::string cell = "—";
        if (b && m && b->contains("v_mae") && m->contains("v_mae")) {
          const double e = m->at("v_mae").get<double>(), eb = b->at("v_mae").get<double>();
          cell = "error " + (eb > 0 ? format_significant(e / eb, 3) + "×" : std::string("—")) + ", time " +
                 format_significant(m->value("shadow_ms", 0.0) / std::max(1e-9, b->value("shadow_ms", 0.0)), 3) + "×";
          if (hard && hard->contains("v_mae") && e > hard->at("v_mae").get<double>()) cell += ", **worse than hard**";
        }
        md << " " << cell << " |";
      }
      md << "\n";
    }
  }
  // Where the error lives (BenchSuite::object_groups): each method's mean |dV| over each group's
  // pixels, a column per scene and group.
  std::vector<std::pair<const json*, std::string>> group_columns;
  for (const json& s : scene_list)
    if (s.contains("object_groups"))
      for (const json& g : s.at("object_groups")) group_columns.emplace_back(&s, g.value("pattern", ""));
  if (!group_columns.empty()) {
    md << "\nBy object: each method's mean |dV| (signed in brackets) over the pixels of each scene's objects "
       << "(`compare --objects`), where the error lives.\n\n| method |";
    for (const auto& [s, pattern] : group_columns) {
      size_t pixels = 0;
      for (const json& g : s->at("object_groups"))
        if (g.value("pattern", "") == pattern) pixels = g.value("pixels", size_t{0});
      md << " " << s->value("name", "?") << ": `" << pattern << "` (" << format_grouped(pixels) << " px) |";
    }
    md << "\n|---|";
    for (size_t i = 0; i < group_columns.size(); ++i) md << "---:|";
    md << "\n";
    for (const json& mname : r.at("methods")) {
      const std::string name = mname.get<std::string>();
      md << "| `" << name << "` |";
      for (const auto& [s, pattern] : group_columns) {
        const json* m = find_method(*s, name);
        std::string cell = "—";
        if (m && m->contains("v_objects") && m->at("v_objects").contains(pattern)) {
          const json& e = m->at("v_objects").at(pattern);
          if (e.at("v_mae").is_number())
            cell = format_significant(e["v_mae"].get<double>(), 2) + " (" +
                   fmt::format("{:+.2g}", e["v_mean_signed"].get<double>()) + ")";
        }
        md << " " << cell << " |";
      }
      md << "\n";
    }
  }
  // Each scene's size and what loading it cost (not in the methods' times).
  for (const json& s : r.at("scenes")) {
    if (!s.contains("load_ms")) continue;
    std::string line = fmt::format("\n- {}: {} triangles; scene load {} ms", s.value("name", "?"),
                                   format_grouped(s.value("triangles", uint64_t{0})),
                                   format_significant(s.value("load_ms", 0.0), 3));
    if (s.contains("embree")) {
      const json& e = s["embree"];
      line += fmt::format(", Embree build {} ms ({} BVHs, {} instances, {} triangles stored, {})",
                          format_significant(e.value("build_ms", 0.0), 3), e.value("geometries", 0),
                          e.value("instances", 0), format_grouped(e.value("stored_triangles", uint64_t{0})),
                          format_bytes(e.value("bytes", uint64_t{0})));
    }
    if (s.contains("peak_rss_bytes")) line += fmt::format("; peak resident memory {}", format_bytes(s.value("peak_rss_bytes", uint64_t{0})));
    md << line << "\n";
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
