// The ground truth of a comparison: the `reference` method (ray tracing the real geometry)
// at reference_spp light samples, rendered once and cached on disk, keyed by a hash of
// everything that determines its pixels (docs/compare.md, "The reference cache"):
// the canonical scene document (after settings), the size and modification time of every
// mesh file it reads, reference_spp, the seed, the reference's parameter overrides and the
// identity (size, modification time) of the running program, so a rebuilt penumbra never
// trusts an image an older build made.
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "penumbra/core/image.h"
#include "penumbra/eval/run_setup.h"

namespace penumbra {

class Progress;

// Who measured a time (issue 32): the machine (machine_identity(): host, CPU model, logical
// cores) and the worker threads. The images of the cache do not depend on the thread count
// (core/parallel.h); their times do. So a cached time is a speed-up's basis only where the same
// machine and thread count measured it; elsewhere the reference is timed again.
struct TimingOrigin {
  std::string machine;
  int threads = 0;
  bool operator==(const TimingOrigin&) const = default;
};
// This process now: its machine and max_threads().
TimingOrigin current_timing_origin();

// Where a time of the reference (the ground truth's, a ladder rung's) comes from.
enum class TimeBasis {
  kMeasuredNow,      // rendered and timed in this run
  kCachedHere,       // from the cache, measured on this machine with this thread count
  kCachedElsewhere,  // from the cache, measured on another machine or with other threads: never
                     // a speed-up's basis
};
// "measured now", "from the cache, same machine and threads", "from the cache, another machine
// or thread count".
const char* time_basis_text(TimeBasis b);
// results.json's names: "measured", "cached_here", "cached_elsewhere" (and back; an unknown name
// is kCachedElsewhere).
const char* time_basis_name(TimeBasis b);
TimeBasis time_basis_from_name(const std::string& name);

// A cache entry keeps its times per origin: "timings", a list of {"machine", "threads", ...}.
// The record `origin` measured, or null.
nlohmann::json find_timing(const nlohmann::json& entry, const TimingOrigin& origin);
// Adds `times` (an object) as `origin`'s record, replacing an older one of the same origin.
void put_timing(nlohmann::json& entry, const TimingOrigin& origin, nlohmann::json times);

struct GroundTruth {
  Image color;       // linear RGB
  Image visibility;  // V
  int light_samples = 0;
  uint64_t seed = 0;              // the seed actually used (ground_truth_seed)
  nlohmann::json params;          // the reference's resolved parameters
  double total_ms = 0;            // of the render that made it (possibly an earlier run)
  double camera_pass_ms = 0;
  nlohmann::json stats;           // MethodStats::to_json() of that render
  TimeBasis time_basis = TimeBasis::kMeasuredNow;  // where total_ms and the stats come from
  bool from_cache = false;
  std::string key;                // the cache key (32 hex digits)
  std::filesystem::path cache_file;  // the .exr, when cached or written
};

// $PENUMBRA_CACHE_DIR, else $XDG_CACHE_HOME/penumbra, else $HOME/.cache/penumbra, else
// an empty path (no cache).
std::filesystem::path default_cache_dir();

// The ground truth renders with a seed different from the methods' (so `reference` at
// equal spp in the method list shows its real noise instead of a zero error).
uint64_t ground_truth_seed(uint64_t seed);

// The cache key and the canonical document it hashes.
std::string ground_truth_key(const RunSetup& setup, nlohmann::json* key_document = nullptr);

// Whether the cache holds this ground truth (cache_dir empty: never).
bool ground_truth_cached(const RunSetup& setup, const std::filesystem::path& cache_dir);

// Loads the ground truth from `cache_dir` or renders it (and stores it there; a cache that
// cannot be written is reported on stderr and skipped). `scene` is setup.load().
// `progress` (optional) is advanced while rendering.
GroundTruth ground_truth(const RunSetup& setup, const Scene& scene, const std::filesystem::path& cache_dir,
                         Progress* progress = nullptr);

// Makes `truth`'s time one this machine measured with this thread count, for a speed-up over
// it: a time from the cache that another machine or thread count measured (kCachedElsewhere)
// is measured again by rendering the ground truth once more (its image is not used: the cached
// one is the same), and the cache entry records it beside the others. Otherwise nothing.
void time_ground_truth(GroundTruth& truth, const RunSetup& setup, const Scene& scene,
                       const std::filesystem::path& cache_dir, Progress* progress = nullptr);

// --- The reference ladder of the equal-quality search (eval/equal_quality.h): the reference
// at 1, 2, 4, ... light samples measured against the ground truth. Its entries hold numbers
// only (errors and times, reference-ladder-<key>.json, a few hundred bytes), keyed by the
// ground truth's key (so everything that changes the ground truth changes them), the rung's
// light samples and its seed: rungs of different sample counts never collide.

// The ladder renders with a seed of its own, distinct from the methods' and the ground truth's.
uint64_t ladder_seed(uint64_t seed);
std::string ladder_rung_key(const RunSetup& setup, int light_samples);
// The cached entry (the object store_ladder_rung wrote), or null when absent or damaged.
nlohmann::json load_ladder_rung(const std::filesystem::path& cache_dir, const std::string& key);
// Writes the entry; a cache that cannot be written is reported on stderr and skipped.
void store_ladder_rung(const std::filesystem::path& cache_dir, const std::string& key, const nlohmann::json& entry);

// Removes the oldest cache entries until the folder holds at most `max_bytes`.
void prune_cache(const std::filesystem::path& cache_dir, uintmax_t max_bytes);

}  // namespace penumbra
