// Light-space data on disk (`--map-cache DIR`, RenderSettings::map_cache; issue 18 part 4,
// docs/animation.md "Maps on disk"): xie2007 weighs its maps' time against their memory and
// disk, agrawala2000 precomputes the LDI once for many displays. A method that can
// (ShadowMethod::stores_prepared, today `lam`) has its prepared data written after prepare()
// and read back instead of prepare() the next time the same inputs come: a second run with
// the same lights and geometry starts at display cost.
//
// An entry is keyed by a digest of everything prepare() may read: the scene's geometry and
// materials (every object's positions, normals, indices, opacities, closedness and analytic
// sphere), the light, the light's index, the method and its resolved parameters, the seed,
// the light samples, the entry format and the program (its file's size and modification
// time: another build never trusts an entry). The camera is not in the key. Entries are
// written whole (temporary file + rename) with a digest of their bytes, so a truncated or
// damaged entry reads as a miss and is written again.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "penumbra/shadow/shadow_method.h"

namespace penumbra {

struct MapCacheStats {
  int hits = 0, misses = 0;  // lights whose method stores its data: read back, or prepared
  int stored = 0;            // entries written (a miss whose entry could not be written is not)
  uint64_t bytes_read = 0, bytes_written = 0;
  double load_ms = 0, store_ms = 0;
  double hit_rate() const { return hits + misses > 0 ? static_cast<double>(hits) / (hits + misses) : 0.0; }
};

class MapCache {
 public:
  // Creates `dir` if needed; throws an Error naming it where it cannot be (a file of that
  // name, no permission).
  explicit MapCache(std::filesystem::path dir);

  // The digest of the scene's geometry and materials (32 hex digits): computed once per
  // geometry by the caller and passed to key().
  static std::string geometry_digest(const Scene& scene);
  // The key of one light's prepared data (32 hex digits).
  static std::string key(const std::string& geometry_digest, const std::string& method,
                         const nlohmann::json& resolved_params, const ShadowContext& ctx);

  // Reads the entry of `key` into `method` (ShadowMethod::load_prepared): true on a hit. A
  // missing, damaged or unreadable entry is a miss.
  bool load(const std::string& key, const std::string& method_name, ShadowMethod& method, const ShadowContext& ctx);
  // Writes `method`'s prepared data as the entry of `key`. A failure (a full disk) is
  // reported on stderr once and the render goes on without the entry.
  void store(const std::string& key, const std::string& method_name, const ShadowMethod& method);

  const std::filesystem::path& dir() const { return dir_; }
  const MapCacheStats& stats() const { return stats_; }
  // The entry file of a key (for tests and messages).
  std::filesystem::path entry_path(const std::string& key, const std::string& method_name) const;
  // The folder's entries: count and bytes on disk.
  uint64_t entry_bytes(int* entries = nullptr) const;
  // --stats-json's "map_cache": the folder, hits, misses, hit rate, bytes read and written,
  // load and store times, and the entries on disk.
  nlohmann::json stats_json() const;

 private:
  std::filesystem::path dir_;
  MapCacheStats stats_;
  bool warned_ = false;
};

}  // namespace penumbra
