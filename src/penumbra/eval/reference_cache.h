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

struct GroundTruth {
  Image color;       // linear RGB
  Image visibility;  // V
  int light_samples = 0;
  uint64_t seed = 0;              // the seed actually used (ground_truth_seed)
  nlohmann::json params;          // the reference's resolved parameters
  double total_ms = 0;            // of the render that made it (possibly an earlier run)
  double camera_pass_ms = 0;
  nlohmann::json stats;           // MethodStats::to_json() of that render
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
