#include "penumbra/viewer/preview_choice.h"

#include <gtest/gtest.h>

namespace penumbra::viewer {
namespace {
namespace PENUMBRA_UNITY_ID {

TEST(PreviewChooser, LeastErrorWithinTheTargetFromWhatWasMeasured) {
  PreviewChooser c({"a", "b", "c", "d"}, /*target_ms=*/50);
  auto never = [](const std::string&) { return false; };
  // Nothing measured: the fallback (the final method), said so.
  PreviewChooser::Choice ch = c.choose(true, never, "final");
  EXPECT_EQ(ch.method, "final");
  EXPECT_LT(ch.ms, 0);
  EXPECT_EQ(c.next_to_calibrate(), "a");
  //          light_ms camera_ms error
  c.record_calibration("a", 200, 5, 0.01, 0.25f);  // accurate, slow to build, fast to redisplay
  c.record_calibration("b", 40, 35, 0.03, 0.25f);  // fits the target either way
  c.record_calibration("c", 10, 10, 0.20, 0.25f);  // fast and poor
  c.record_failure("d");                           // cannot render the scene
  EXPECT_EQ(c.next_to_calibrate(), "");
  // A light move: a's structures must be rebuilt (200 ms > 50): b, the least error that fits.
  ch = c.choose(true, never, "final");
  EXPECT_EQ(ch.method, "b");
  EXPECT_DOUBLE_EQ(ch.ms, 40);
  EXPECT_DOUBLE_EQ(ch.error, 0.03);
  // A camera move with a's structures ready for the lights: a redisplays in 5 ms.
  auto a_ready = [](const std::string& m) { return m == "a"; };
  EXPECT_EQ(c.choose(false, a_ready, "final").method, "a");
  // ... but not when they are not.
  EXPECT_EQ(c.choose(false, never, "final").method, "b");
  // Nothing within a tighter target: the fastest (the failed d never).
  PreviewChooser tight({"a", "b", "c", "d"}, 5);
  for (const auto& [name, m] : c.measurements())
    if (m.failed) tight.record_failure(name);
    else tight.record_calibration(name, m.light_ms, m.camera_ms, m.error, m.scale);
  ch = tight.choose(true, never, "final");
  EXPECT_EQ(ch.method, "c");
  EXPECT_NE(ch.reason.find("fastest"), std::string::npos);
  // Errors against an old final method are forgotten: everything is measured again.
  c.reset_errors();
  EXPECT_EQ(c.next_to_calibrate(), "a");
  EXPECT_EQ(c.choose(true, never, "final").method, "final");
  const nlohmann::json j = tight.to_json();
  EXPECT_EQ(j["d"]["failed"], true);
  EXPECT_EQ(j["b"]["light_ms"], 40.0);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::viewer
