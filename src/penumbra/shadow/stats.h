// What a method reports about one prepare/evaluate: per-phase times, work counters and
// memory, plus method-specific figures in `extra` (written by --stats-json).
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/core/timer.h"

namespace penumbra {

struct MethodStats {
  std::vector<std::pair<std::string, double>> phases_ms;  // in the order first reported
  uint64_t rays_traced = 0;     // shadow rays through geometry or depth images
  uint64_t texels_visited = 0;  // texels/nodes touched in light-space structures
  uint64_t memory_bytes = 0;    // peak size of the method's light-space structures
  uint64_t prepare_count = 0;   // how many times prepare() rebuilt the structures
  nlohmann::json extra = nlohmann::json::object();

  void add_phase(const std::string& name, double ms);
  double phase(const std::string& name) const;  // 0 if absent
  double total_ms() const;
  // Adds counters and phase times of `o` into this (per-light stats into a frame's).
  void accumulate(const MethodStats& o);
  // Adds n to the counter extra[key] (0 if absent): what one evaluate counts, summed over the
  // evaluates of a frame (the light-space partitions, partitions::wrap, evaluate one map after
  // another; the renderer resets the statistics between frames).
  void add_count(const std::string& key, uint64_t n);
  nlohmann::json to_json() const;
};

// Times a scope into stats.phases_ms[name].
class ScopedPhase {
 public:
  ScopedPhase(MethodStats& stats, std::string name) : stats_(stats), name_(std::move(name)) {}
  ~ScopedPhase() { stats_.add_phase(name_, timer_.elapsed_ms()); }

 private:
  MethodStats& stats_;
  std::string name_;
  Timer timer_;
};

}  // namespace penumbra
