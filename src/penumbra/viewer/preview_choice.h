// The viewer's auto preview (docs/viewer.md, "The auto preview"): which method previews a view
// while it moves, chosen from what the session has measured on its own device, never from a
// fixed list (issue 30 part 2). Every method that runs on the device is a candidate. Once the
// final method has refined a view, the session calibrates the candidates one by one in idle time
// (ViewerSession's calibration jobs): each renders the view at the calibration scale twice,
//   light_ms    its first render, with its light-space structures built: what a preview costs
//               after a light moved;
//   camera_ms   its second render, over the same structures: what it costs after only the
//               camera moved;
//   error       its mean |dV| against the final method's refined V at that scale.
// All candidates are measured at the same pixel count, so their times compare; the preview
// itself then renders the chosen method at the auto scale that keeps it within the target. The
// choice for a moving view: the
// candidate of least error whose time for that kind of move (camera_ms only where its
// structures are ready for the current lights) fits the frame-time target; none fits: the
// fastest; nothing measured yet: the final method (the auto scale then keeps it interactive).
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace penumbra::viewer {

struct PreviewMeasurement {
  double light_ms = -1;   // < 0: not measured
  double camera_ms = -1;
  double error = -1;      // mean |dV| against the final method's V
  float scale = 0;        // the fraction of the view's pixels it was measured at
  bool failed = false;    // the method refused this scene (memory, a light shape): never chosen
};

class PreviewChooser {
 public:
  PreviewChooser(std::vector<std::string> candidates, double target_ms)
      : candidates_(std::move(candidates)), target_ms_(target_ms) {}

  const std::vector<std::string>& candidates() const { return candidates_; }
  // The next candidate without measurements (in candidate order), or "" when all have them.
  std::string next_to_calibrate() const;
  void record_calibration(const std::string& method, double light_ms, double camera_ms, double error, float scale);
  void record_failure(const std::string& method);
  // Forget every measurement (the scene's geometry is the same, but the final method or its
  // settings changed: the errors were against another reference).
  void reset_errors();

  struct Choice {
    std::string method;
    double ms = -1;     // the time that decided it (< 0: not measured)
    double error = -1;
    std::string reason;  // "least error within the frame-time target", ...
  };
  // The method to preview a move with; `ready(m)`: m's light-space structures serve the current
  // lights (then a camera move costs camera_ms).
  Choice choose(bool after_light_move, const std::function<bool(const std::string&)>& ready,
                const std::string& fallback) const;

  const std::map<std::string, PreviewMeasurement>& measurements() const { return measured_; }
  nlohmann::json to_json() const;

 private:
  std::vector<std::string> candidates_;
  double target_ms_;
  std::map<std::string, PreviewMeasurement> measured_;
};

}  // namespace penumbra::viewer
