#include "penumbra/viewer/preview_choice.h"

#include <algorithm>

namespace penumbra::viewer {

std::string PreviewChooser::next_to_calibrate() const {
  for (const std::string& m : candidates_) {
    auto it = measured_.find(m);
    if (it == measured_.end() || (!it->second.failed && it->second.error < 0)) return m;
  }
  return "";
}

void PreviewChooser::record_calibration(const std::string& method, double light_ms, double camera_ms, double error,
                                        float scale) {
  PreviewMeasurement& m = measured_[method];
  m.light_ms = light_ms;
  m.camera_ms = camera_ms;
  m.error = error;
  m.scale = scale;
  m.failed = false;
}

void PreviewChooser::record_failure(const std::string& method) { measured_[method].failed = true; }

void PreviewChooser::reset_errors() {
  for (auto& [name, m] : measured_) m.error = -1;
}

PreviewChooser::Choice PreviewChooser::choose(bool after_light_move,
                                              const std::function<bool(const std::string&)>& ready,
                                              const std::string& fallback) const {
  // A move's cost: camera_ms only where the method's structures serve the current lights.
  auto cost = [&](const std::string& name, const PreviewMeasurement& m) {
    if (!after_light_move && ready(name) && m.camera_ms >= 0) return m.camera_ms;
    return m.light_ms;
  };
  const Choice none{fallback, -1, -1, "nothing measured yet: the final method at a scale that keeps it interactive"};
  Choice best, fastest;
  for (const std::string& name : candidates_) {
    auto it = measured_.find(name);
    if (it == measured_.end() || it->second.failed || it->second.error < 0) continue;
    const double t = cost(name, it->second);
    if (t < 0) continue;
    if (fastest.method.empty() || t < fastest.ms) fastest = {name, t, it->second.error, ""};
    if (t > target_ms_) continue;
    if (best.method.empty() || it->second.error < best.error || (it->second.error == best.error && t < best.ms))
      best = {name, t, it->second.error, ""};
  }
  if (!best.method.empty()) {
    best.reason = "least error against the final method within the frame-time target";
    return best;
  }
  if (!fastest.method.empty()) {
    fastest.reason = "none within the frame-time target: the fastest";
    return fastest;
  }
  return none;
}

nlohmann::json PreviewChooser::to_json() const {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [name, m] : measured_) {
    auto num = [](double v) { return v < 0 ? nlohmann::json(nullptr) : nlohmann::json(v); };
    out[name] = {{"light_ms", num(m.light_ms)}, {"camera_ms", num(m.camera_ms)}, {"error", num(m.error)},
                 {"scale", m.scale}, {"failed", m.failed}};
  }
  return out;
}

}  // namespace penumbra::viewer
