#include "penumbra/eval/reference_cache.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <map>
#include <system_error>
#include <vector>

#include <fmt/format.h>

#include "penumbra/core/file_util.h"
#include "penumbra/core/hash.h"
#include "penumbra/core/interrupt.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/program_identity.h"
#include "penumbra/core/progress.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene/json_reader.h"

namespace penumbra {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// 2: the meta file holds the EXR's checksum.
constexpr int kCacheFormat = 2;

// FNV-1a of a file's bytes (the cache's check that an EXR is the one its meta file
// describes: a truncated, overwritten or bit-flipped entry reads as a miss).
std::string file_checksum(const fs::path& p) {
  const std::string bytes = read_text_file(p);
  return fmt::format("{:016x}", fnv1a(bytes, 0xcbf29ce484222325ull, false));
}

}  // namespace

TimingOrigin current_timing_origin() { return {machine_identity(), max_threads()}; }

namespace {
// Each TimeBasis's name in results.json and its words, in the order of the enum.
struct TimeBasisWords {
  const char* name;
  const char* text;
};
constexpr TimeBasisWords kTimeBasisWords[] = {
    {"measured", "measured now"},
    {"cached_here", "from the cache, same machine and threads"},
    {"cached_elsewhere", "from the cache, another machine or thread count"}};
static_assert(std::size(kTimeBasisWords) == static_cast<size_t>(TimeBasis::kCachedElsewhere) + 1);
}  // namespace

const char* time_basis_text(TimeBasis b) { return kTimeBasisWords[static_cast<int>(b)].text; }
const char* time_basis_name(TimeBasis b) { return kTimeBasisWords[static_cast<int>(b)].name; }

TimeBasis time_basis_from_name(const std::string& name) {
  for (size_t b = 0; b < std::size(kTimeBasisWords); ++b)
    if (name == kTimeBasisWords[b].name) return static_cast<TimeBasis>(b);
  return TimeBasis::kCachedElsewhere;
}

namespace {
bool measured_by(const json& record, const TimingOrigin& origin) {
  return record.is_object() && record.value("machine", "") == origin.machine &&
         record.value("threads", -1) == origin.threads;
}
}  // namespace

json find_timing(const json& entry, const TimingOrigin& origin) {
  if (!entry.is_object() || !entry.contains("timings") || !entry["timings"].is_array()) return nullptr;
  for (const json& t : entry["timings"])
    if (measured_by(t, origin)) return t;
  return nullptr;
}

void put_timing(json& entry, const TimingOrigin& origin, json times) {
  json& all = entry["timings"];
  if (!all.is_array()) all = json::array();
  for (auto it = all.begin(); it != all.end();) it = measured_by(*it, origin) ? all.erase(it) : std::next(it);
  times["machine"] = origin.machine;
  times["threads"] = origin.threads;
  all.push_back(std::move(times));  // the newest last
}

fs::path default_cache_dir() {
  if (const char* d = std::getenv("PENUMBRA_CACHE_DIR"); d && *d) return fs::path(d);
  if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d) return fs::path(d) / "penumbra";
  if (const char* d = std::getenv("HOME"); d && *d) return fs::path(d) / ".cache" / "penumbra";
  return {};
}

uint64_t ground_truth_seed(uint64_t seed) { return seed ^ 0x9e3779b97f4a7c15ull; }

std::string ground_truth_key(const RunSetup& setup, json* key_document) {
  json files = json::array();
  if (setup.scene_doc.contains("objects") && setup.scene_doc["objects"].is_array()) {
    for (const json& obj : setup.scene_doc["objects"]) {
      if (!obj.is_object() || !obj.contains("mesh") || !obj["mesh"].is_string()) continue;
      fs::path mesh = obj["mesh"].get<std::string>();
      if (mesh.is_relative()) mesh = setup.scene_path.parent_path() / mesh;
      files.push_back(file_identity(mesh));
    }
  }
  json doc = {{"format", kCacheFormat},
              {"scene", setup.scene_doc},
              {"files", files},
              {"reference_spp", setup.reference_samples},
              {"seed", ground_truth_seed(setup.seed)},
              {"params", setup.overrides_for("reference", /*explicit_only=*/true)},
              {"program", program_identity()}};
  // The frames of an animated scene share its document: the frame tells their ground truths
  // apart (issue 18). Absent for the scene as written, so its keys stay what they were.
  if (setup.frame >= 0) doc["frame"] = setup.frame;
  // nlohmann::json keeps object keys sorted: dump() is canonical.
  std::string text = doc.dump();
  if (key_document) *key_document = doc;
  return fmt::format("{:016x}{:016x}", fnv1a(text, 0xcbf29ce484222325ull, false),
                     fnv1a(text, 0x84222325cbf29ce4ull, true));
}

namespace {

struct CachePaths {
  fs::path exr, meta;
};
CachePaths cache_paths(const fs::path& dir, const std::string& key) {
  return {dir / fmt::format("reference-{}.exr", key), dir / fmt::format("reference-{}.json", key)};
}

json truth_times_json(const GroundTruth& gt) {
  return {{"total_ms", gt.total_ms}, {"camera_pass_ms", gt.camera_pass_ms}, {"stats", gt.stats}};
}

// The entry's times: those this machine measured with this thread count, else the newest
// record (another machine's or thread count's: kCachedElsewhere). Throws on a damaged entry.
void read_cached_times(const json& meta, GroundTruth* gt) {
  json t = find_timing(meta, current_timing_origin());
  gt->time_basis = TimeBasis::kCachedHere;
  if (t.is_null()) {
    t = meta.at("timings").at(meta.at("timings").size() - 1);
    gt->time_basis = TimeBasis::kCachedElsewhere;
  }
  gt->total_ms = t.at("total_ms").get<double>();
  gt->camera_pass_ms = t.at("camera_pass_ms").get<double>();
  gt->stats = t.at("stats");
}

RenderSettings ground_truth_settings(const RunSetup& setup, Progress* progress) {
  RenderSettings settings;
  settings.method = "reference";
  settings.params = setup.overrides_for("reference", /*explicit_only=*/true);
  settings.light_samples = setup.reference_samples;
  settings.seed = ground_truth_seed(setup.seed);
  settings.progress_bar = progress;
  return settings;
}

bool load_cached(const fs::path& dir, const std::string& key, int width, int height, GroundTruth* out) {
  CachePaths p = cache_paths(dir, key);
  std::error_code ec;
  if (!fs::exists(p.exr, ec) || !fs::exists(p.meta, ec)) return false;
  try {
    json meta = json::parse(read_text_file(p.meta));
    if (meta.value("key", "") != key) return false;
    if (meta.value("exr_checksum", "") != file_checksum(p.exr)) return false;
    Image color = read_image(p.exr.string());
    Image v = read_exr_channel(p.exr.string(), "V");
    if (color.width() != width || color.height() != height || v.width() != width || v.height() != height ||
        color.channels() != 3)
      return false;
    out->color = std::move(color);
    out->visibility = std::move(v);
    out->light_samples = meta.at("reference_spp").get<int>();
    out->seed = meta.at("seed").get<uint64_t>();
    out->params = meta.at("params");
    read_cached_times(meta, out);
    out->from_cache = true;
    out->key = key;
    out->cache_file = p.exr;
    // Touch the entry so that pruning removes the least recently used first.
    fs::last_write_time(p.meta, fs::file_time_type::clock::now(), ec);
    return true;
  } catch (const Interrupted&) {
    throw;  // Ctrl-C ends the run, whatever this step would do with an error
  } catch (const std::exception&) {
    return false;  // a damaged entry is rendered again and overwritten
  }
}

}  // namespace

bool ground_truth_cached(const RunSetup& setup, const fs::path& cache_dir) {
  if (cache_dir.empty()) return false;
  CachePaths p = cache_paths(cache_dir, ground_truth_key(setup));
  std::error_code ec;
  return fs::exists(p.exr, ec) && fs::exists(p.meta, ec);
}

GroundTruth ground_truth(const RunSetup& setup, const Scene& scene, const fs::path& cache_dir, Progress* progress) {
  json key_doc;
  GroundTruth gt;
  gt.key = ground_truth_key(setup, &key_doc);
  if (!cache_dir.empty() && load_cached(cache_dir, gt.key, scene.camera.width, scene.camera.height, &gt)) return gt;

  const RenderSettings settings = ground_truth_settings(setup, progress);
  RenderResult r = render_scene(scene, settings);
  gt.color = std::move(r.color);
  gt.visibility = std::move(r.visibility);
  gt.light_samples = setup.reference_samples;
  gt.seed = settings.seed;
  gt.params = r.resolved_params;
  gt.total_ms = r.total_ms;
  gt.camera_pass_ms = r.camera_pass_ms;
  gt.stats = r.stats.to_json();
  gt.time_basis = TimeBasis::kMeasuredNow;
  gt.from_cache = false;

  if (!cache_dir.empty()) {
    try {
      fs::create_directories(cache_dir);
      CachePaths p = cache_paths(cache_dir, gt.key);
      write_image(p.exr.string(), gt.color, {{"V", &gt.visibility}});
      json meta = {{"key", gt.key},
                   {"reference_spp", gt.light_samples},
                   {"seed", gt.seed},
                   {"params", gt.params},
                   {"scene", setup.scene_path.string()},
                   {"exr_checksum", file_checksum(p.exr)},
                   {"key_document", key_doc}};
      put_timing(meta, current_timing_origin(), truth_times_json(gt));
      write_text_file_atomic(p.meta, meta.dump(1) + "\n");
      gt.cache_file = p.exr;
      prune_cache(cache_dir, uintmax_t(2) << 30);
    } catch (const Interrupted&) {
      throw;  // Ctrl-C ends the run, whatever this step would do with an error
    } catch (const std::exception& e) {
      std::fprintf(stderr, "penumbra: warning: reference cache %s not written: %s\n", cache_dir.string().c_str(),
                   e.what());
    }
  }
  return gt;
}

void time_ground_truth(GroundTruth& truth, const RunSetup& setup, const Scene& scene, const fs::path& cache_dir,
                       Progress* progress) {
  if (truth.time_basis != TimeBasis::kCachedElsewhere) return;
  const RenderResult r = render_scene(scene, ground_truth_settings(setup, progress));
  truth.total_ms = r.total_ms;
  truth.camera_pass_ms = r.camera_pass_ms;
  truth.stats = r.stats.to_json();
  truth.time_basis = TimeBasis::kMeasuredNow;
  if (cache_dir.empty() || !truth.from_cache) return;
  try {
    const CachePaths p = cache_paths(cache_dir, truth.key);
    json meta = json::parse(read_text_file(p.meta));
    put_timing(meta, current_timing_origin(), truth_times_json(truth));
    write_text_file_atomic(p.meta, meta.dump(1) + "\n");
  } catch (const Interrupted&) {
    throw;  // Ctrl-C ends the run, whatever this step would do with an error
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra: warning: reference cache %s: the new time not recorded: %s\n",
                 cache_dir.string().c_str(), e.what());
  }
}

uint64_t ladder_seed(uint64_t seed) { return seed ^ 0xd1b54a32d192ed03ull; }

std::string ladder_rung_key(const RunSetup& setup, int light_samples) {
  json doc = {{"format", kCacheFormat},
              {"ladder_of", ground_truth_key(setup)},
              {"spp", light_samples},
              {"seed", ladder_seed(setup.seed)}};
  std::string text = doc.dump();
  return fmt::format("{:016x}{:016x}", fnv1a(text, 0xcbf29ce484222325ull, false),
                     fnv1a(text, 0x84222325cbf29ce4ull, true));
}

namespace {
fs::path ladder_path(const fs::path& dir, const std::string& key) {
  return dir / fmt::format("reference-ladder-{}.json", key);
}
}  // namespace

json load_ladder_rung(const fs::path& cache_dir, const std::string& key) {
  if (cache_dir.empty()) return nullptr;
  fs::path p = ladder_path(cache_dir, key);
  std::error_code ec;
  if (!fs::exists(p, ec)) return nullptr;
  try {
    json entry = json::parse(read_text_file(p));
    if (!entry.is_object() || entry.value("key", "") != key) return nullptr;
    fs::last_write_time(p, fs::file_time_type::clock::now(), ec);  // least recently used goes first
    return entry;
  } catch (const Interrupted&) {
    throw;  // Ctrl-C ends the run, whatever this step would do with an error
  } catch (const std::exception&) {
    return nullptr;  // a damaged entry is rendered again and overwritten
  }
}

void store_ladder_rung(const fs::path& cache_dir, const std::string& key, const json& entry) {
  if (cache_dir.empty()) return;
  try {
    fs::create_directories(cache_dir);
    json e = entry;
    e["key"] = key;
    write_text_file_atomic(ladder_path(cache_dir, key), e.dump(1) + "\n");
  } catch (const Interrupted&) {
    throw;  // Ctrl-C ends the run, whatever this step would do with an error
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "penumbra: warning: reference cache %s not written: %s\n", cache_dir.string().c_str(),
                 ex.what());
  }
}

void prune_cache(const fs::path& cache_dir, uintmax_t max_bytes) {
  struct Entry {
    fs::file_time_type time;
    uintmax_t bytes = 0;
    std::vector<fs::path> files;
  };
  std::error_code ec;
  std::map<std::string, Entry> entries;  // by key
  for (const auto& f : fs::directory_iterator(cache_dir, ec)) {
    std::string name = f.path().filename().string();
    if (name.rfind("reference-", 0) != 0) continue;
    std::string key = f.path().stem().string();
    Entry& e = entries[key];
    e.bytes += f.file_size(ec);
    auto t = f.last_write_time(ec);
    if (e.files.empty() || t > e.time) e.time = t;
    e.files.push_back(f.path());
  }
  uintmax_t total = 0;
  std::vector<Entry*> order;
  for (auto& [k, e] : entries) {
    total += e.bytes;
    order.push_back(&e);
  }
  std::sort(order.begin(), order.end(), [](const Entry* a, const Entry* b) { return a->time < b->time; });
  for (Entry* e : order) {
    if (total <= max_bytes) break;
    for (const auto& f : e->files) fs::remove(f, ec);
    total -= e->bytes;
  }
}

}  // namespace penumbra
