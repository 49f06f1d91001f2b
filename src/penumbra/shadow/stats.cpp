#include "penumbra/shadow/stats.h"

namespace penumbra {

void MethodStats::add_phase(const std::string& name, double ms) {
  for (auto& [n, t] : phases_ms)
    if (n == name) {
      t += ms;
      return;
    }
  phases_ms.emplace_back(name, ms);
}

double MethodStats::phase(const std::string& name) const {
  for (const auto& [n, t] : phases_ms)
    if (n == name) return t;
  return 0.0;
}

double MethodStats::total_ms() const {
  double s = 0;
  for (const auto& [n, t] : phases_ms) s += t;
  return s;
}

void MethodStats::accumulate(const MethodStats& o) {
  for (const auto& [n, t] : o.phases_ms) add_phase(n, t);
  rays_traced += o.rays_traced;
  texels_visited += o.texels_visited;
  memory_bytes += o.memory_bytes;
  prepare_count += o.prepare_count;
  for (auto it = o.extra.begin(); it != o.extra.end(); ++it) extra[it.key()] = it.value();
}

void MethodStats::add_count(const std::string& key, uint64_t n) {
  extra[key] = extra.value(key, uint64_t{0}) + n;
}

nlohmann::json MethodStats::to_json() const {
  nlohmann::json phases = nlohmann::json::object();
  for (const auto& [n, t] : phases_ms) phases[n] = t;
  return {{"phases_ms", phases},   {"total_ms", total_ms()},         {"rays_traced", rays_traced},
          {"texels_visited", texels_visited}, {"memory_bytes", memory_bytes}, {"prepare_count", prepare_count},
          {"extra", extra}};
}

}  // namespace penumbra
