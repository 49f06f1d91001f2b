// Shared pieces of the comparison tests: a tiny run of the contact scene (32 x 32 pixels,
// a few light samples) and a temporary folder per test. Header-only; tests only.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include <fmt/format.h>

#include "penumbra/eval/run_setup.h"
#include "penumbra/testing/cli_run.h"  // slurp

namespace penumbra::testing {

// contact.json (2,222 triangles) at 32 x 32, 4 light samples, a 16-sample ground truth.
inline RunSetup tiny_contact_setup() {
  RunSetup s = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/contact.json");
  s.apply("resolution", "32");
  s.light_samples = 4;
  s.reference_samples = 16;
  return s;
}

// The same, animated (issue 18): the camera moves `move` sideways over `frames` frames (linear
// keys at the first and last; 0: every frame is the same), the light and the objects stay.
inline RunSetup tiny_animated_contact_setup(int frames = 3, double move = 0.4) {
  RunSetup s = tiny_contact_setup();
  s.scene_doc["animation"] = nlohmann::json::parse(fmt::format(
      R"({{"frames": {0}, "fps": 24, "camera": {{"eye": {{"interpolation": "linear", "keys": [
           {{"frame": 0, "value": [0.6, 1.3, 2.6]}}, {{"frame": {1}, "value": [{2}, 1.3, 2.6]}}]}}}}}})",
      frames, frames - 1, 0.6 + move));
  return s;
}

// A fresh folder under the system temp folder, removed when the fixture goes.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::temp_directory_path() /
            fmt::format("penumbra-{}-{}-{}", ::getpid(), info ? info->test_suite_name() : "x", info ? info->name() : "y");
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

}  // namespace penumbra::testing
