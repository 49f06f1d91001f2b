#include "penumbra/eval/temporal.h"

#include <gtest/gtest.h>

#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/eval/reference_cache.h"
#include "penumbra/testing/compare_fixture.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::TempDir;
using testing::tiny_animated_contact_setup;

// A ground truth of `frames` frames that changes from frame to frame and pixel to pixel.
std::vector<Image> moving_truth(int frames) {
  std::vector<Image> g;
  for (int t = 0; t < frames; ++t) {
    Image im(5, 4, 1);
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 5; ++x) im.at(x, y) = 0.5f + 0.1f * std::sin(0.7f * x + 1.3f * y + 0.9f * t);
    g.push_back(im);
  }
  return g;
}

TEST(Temporal, ASequenceEqualToTheGroundTruthHasNoInstability) {
  const std::vector<Image> g = moving_truth(5);
  EXPECT_EQ(temporal_instability(g, g), 0.0);
}

TEST(Temporal, AlternatingNoiseOfSizeEGivesTwoE) {
  // V_t = G_t + (-1)^t e: every frame-to-frame change is off by exactly 2e.
  const float e = 0.03f;
  const std::vector<Image> g = moving_truth(6);
  std::vector<Image> v = g;
  for (size_t t = 0; t < v.size(); ++t)
    for (float& x : v[t].data()) x += (t % 2 ? -e : e);
  EXPECT_NEAR(temporal_instability(v, g), 2 * e, 1e-6);
}

TEST(Temporal, AConstantErrorDoesNotFlicker) {
  // A bias the same in every frame is per-frame error, not instability.
  const std::vector<Image> g = moving_truth(4);
  std::vector<Image> v = g;
  for (Image& im : v)
    for (float& x : im.data()) x -= 0.2f;
  EXPECT_NEAR(temporal_instability(v, g), 0.0, 1e-7);
  EXPECT_NEAR(frame_flicker(v[1], v[2], g[1], g[2]), 0.0, 1e-7);
}

TEST(Temporal, OneFrameIsNaNAndMismatchesThrow) {
  const std::vector<Image> g = moving_truth(3);
  EXPECT_TRUE(std::isnan(temporal_instability({g[0]}, {g[0]})));
  EXPECT_THROW(temporal_instability(g, {g[0], g[1]}), Error);
  EXPECT_THROW(frame_flicker(g[0], Image(3, 3, 1), g[1], g[2]), Error);
}

TEST(Temporal, EachFrameHasAGroundTruthOfItsOwn) {
  // The frames share one document: the frame keeps their cache entries apart, and a setup
  // without a frame keeps the key it always had (no frame in the key document).
  RunSetup s = tiny_animated_contact_setup();
  nlohmann::json doc;
  const std::string as_written = ground_truth_key(s, &doc);
  EXPECT_FALSE(doc.contains("frame"));
  s.frame = 0;
  const std::string k0 = ground_truth_key(s);
  s.frame = 1;
  EXPECT_NE(ground_truth_key(s), k0);
  EXPECT_NE(as_written, k0);
  // load() gives the scene at the frame: the camera of frame 1 is not frame 0's.
  const Scene f1 = s.load();
  s.frame = 0;
  EXPECT_NE(s.load().camera.eye.x, f1.camera.eye.x);
}

TEST(Temporal, SequenceComparisonMeasuresEveryFrame) {
  TempDir dir;
  RunSetup setup = tiny_animated_contact_setup(3);
  setup.light_samples = 2;  // few samples: the reference's noise changes with the camera
  CompareOptions o;
  o.methods = {"reference", "hard"};
  o.cache_dir = dir / "cache";
  o.equal_quality = false;
  Comparison c = run_sequence_comparison(setup, o, 0, 3);
  ASSERT_TRUE(c.has_frames);
  EXPECT_EQ(c.frames.begin, 0);
  EXPECT_EQ(c.frames.end, 3);
  ASSERT_EQ(c.frames.methods.size(), 2u);
  EXPECT_EQ(c.frames.truth_cached, (std::vector<bool>{false, false, false}));
  for (const MethodFrames& m : c.frames.methods) {
    ASSERT_TRUE(m.ok) << m.method << ": " << m.error;
    EXPECT_EQ(m.v_mae.size(), 3u);
    EXPECT_EQ(m.shadow_ms_fresh.size(), 3u);
    EXPECT_EQ(m.shadow_ms_reuse.size(), 3u);
    EXPECT_EQ(m.flicker.size(), 2u);
    EXPECT_GT(m.temporal_instability, 0.0) << m.method;
    EXPECT_GT(m.ms_per_frame_fresh, 0.0);
    EXPECT_GT(m.ms_per_frame_reuse, 0.0);
    // Frame 0 is the comparison's own row.
    EXPECT_EQ(m.v_mae[0], (m.method == c.runs[0].method ? c.runs[0] : c.runs[1]).v.mae);
  }
  // The flicker of a frame is at most the errors of its two frames (triangle inequality).
  for (const MethodFrames& m : c.frames.methods)
    for (size_t i = 0; i < m.flicker.size(); ++i) EXPECT_LE(m.flicker[i], m.v_mae[i] + m.v_mae[i + 1] + 1e-9);
  const MethodFrames& hard = c.frames.methods[1];
  // Each frame's colour image is kept for the page's player.
  EXPECT_EQ(c.frames.truth_color.size(), 3u);
  EXPECT_EQ(hard.color.size(), 3u);
  // results.json reads back (comparison_from_json): the sequence, without the images.
  const Comparison back = comparison_from_json(comparison_json(c));
  ASSERT_TRUE(back.has_frames);
  EXPECT_EQ(frame_sequence_json(back.frames), frame_sequence_json(c.frames));
  EXPECT_EQ(back.frames.methods[1].temporal_instability, hard.temporal_instability);
  // Again: every frame's ground truth comes from the cache.
  Comparison again = run_sequence_comparison(setup, o, 1, 3);
  EXPECT_EQ(again.frames.truth_cached, (std::vector<bool>{true, true}));
  EXPECT_EQ(again.frames.methods[1].v_mae[0], hard.v_mae[1]);  // frame 1 alike, hard deterministic
}

TEST(Temporal, AStillSequenceHasNoInstability) {
  // Every frame the same scene: every frame renders with the same seed (as render
  // --frame-range does) and the methods key their samples by pixel, so the frames are equal,
  // the reference's noise included, and nothing flickers, whatever the per-frame error.
  TempDir dir;
  RunSetup setup = tiny_animated_contact_setup(3, 0.0);
  setup.light_samples = 2;
  CompareOptions o;
  o.methods = {"reference", "hard"};
  o.cache_dir = dir / "cache";
  o.equal_quality = false;
  const Comparison c = run_sequence_comparison(setup, o, 0, 3);
  for (const MethodFrames& m : c.frames.methods) {
    ASSERT_TRUE(m.ok) << m.error;
    EXPECT_GT(m.v_mae_mean, 0.0) << m.method;
    EXPECT_EQ(m.temporal_instability, 0.0) << m.method;
    EXPECT_EQ(m.v_mae[0], m.v_mae[2]) << m.method;
  }
}

TEST(Temporal, ASceneWithoutAnimationIsAnError) {
  RunSetup setup = testing::tiny_contact_setup();
  CompareOptions o;
  o.methods = {"hard"};
  try {
    run_sequence_comparison(setup, o, 0, 2);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no \"animation\" block"), std::string::npos) << e.what();
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
