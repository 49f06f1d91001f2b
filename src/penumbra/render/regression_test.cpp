// Every registered method against the ground truth on three shipped scenes (issue 33): the
// bunny (a closed smooth mesh, wide penumbrae), foliage (3,000 alpha-masked leaf quads) and the
// knot (a closed tube shadowing itself). Each method's mean |V - reference| at 64 x 64 pixels and
// 64 light samples (seed 0; the reference at 1024 samples, seed 0) is held to the value measured
// once and kept in kMeasured, plus 25%: a method that gets worse fails, one that gets better
// says that its row can be tightened. The errors are deterministic (every method's result is
// independent of the thread count), so the margin is for other machines' floating point and for
// changes that move an error a little, not for noise.
//
// To measure a new method (or re-measure after an intended change): run
// `build/penumbra_tests --gtest_filter='Methods/MethodRegression.*'`; a method without a row
// fails and prints its three numbers in the table's form.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <iterator>
#include <map>
#include <mutex>
#include <string>

#include "penumbra/eval/metrics.h"
#include "penumbra/eval/run_setup.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/testing/every_method.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

constexpr int kResolution = 64;
constexpr int kLightSamples = 64;
constexpr int kReferenceSamples = 1024;
constexpr double kMargin = 1.25;

const char* const kScenes[] = {"bunny", "foliage", "knot"};

// Mean |V - reference| per scene, measured on the date below at the commit that added or last
// changed the row (git log -p this file), with the settings above.
struct Measured {
  const char* method;
  double bunny, foliage, knot;
};
// The rows of vsm, evsm and msm (their regions in parts), occlusion-textures (the closed
// receivers' horizon; again for open_fade and for the own slice), rt-denoised (V the area fraction), lam (weighted
// splats), mlsm and mtsm (open_self_bias) and multi-view-sm (its foliage at 0.0103 against the
// row's 0.0154: an earlier change's gain, not recorded then) were measured again on 2026-11-28; lam
// (its unresolved points traced), coherent-rt, mlsm and mtsm (their rays' near field) on 2026-12-06,
// and again that day for lam's trace_spread of 0.005 (its foliage 0.00624 -> 0.00679: at 64 light
// samples more points take the traced samples' banding than the interpolation's blend), the near
// field's light-relative length and the multilayer maps' rays behind full texels; multi-view-sm
// (its rays' near field), vsm, evsm and msm (the light centre's ray over their near field) and
// occlusion-textures (the same ray, its depth left out of the slices) on 2026-12-06.
constexpr const char* kMeasuredOn =
    "2026-11-27 (rt-denoised: 2026-11-28; lam, coherent-rt, mlsm, mtsm, multi-view-sm, vsm, evsm, msm, "
    "occlusion-textures: 2026-12-06)";
constexpr Measured kMeasured[] = {
    {"afsm", 0.00253, 0.00673, 0.00283},
    {"afsm-hard", 0.03228, 0.09935, 0.04061},
    {"coherent-rt", 0.00246, 0.00781, 0.00302},
    {"evsm", 0.01493, 0.02856, 0.01725},
    {"hard", 0.03228, 0.09935, 0.04061},
    {"lam", 0.00233, 0.00679, 0.00279},
    {"mlsm", 0.00262, 0.00727, 0.00314},
    {"msm", 0.01543, 0.02680, 0.01466},
    {"mtsm", 0.00262, 0.00727, 0.00314},
    {"multi-view-sm", 0.00220, 0.00706, 0.00259},
    {"occlusion-textures", 0.01528, 0.03787, 0.00735},
    {"pcss", 0.01888, 0.03324, 0.01318},
    {"reference", 0.00258, 0.00704, 0.00296},
    {"rt-denoised", 0.01210, 0.01830, 0.01160},
    {"shadow-map", 0.03224, 0.10161, 0.04062},
    {"single-sample", 0.14614, 0.15552, 0.13547},
    {"ssv-rt", 0.00253, 0.00673, 0.00283},
    {"vsm", 0.01647, 0.02849, 0.01806},
};

Scene load(const std::string& name) {
  RunSetup setup = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name + ".json");
  setup.apply("resolution", std::to_string(kResolution));
  return setup.load();
}

struct Truth {
  Scene scene;
  Image visibility;
};

// The scene and its reference image, rendered once per scene for all the methods' tests.
const Truth& truth(const std::string& name) {
  static std::mutex mutex;
  static std::map<std::string, Truth> cache;
  std::lock_guard<std::mutex> lock(mutex);
  auto it = cache.find(name);
  if (it != cache.end()) return it->second;
  Truth t;
  t.scene = load(name);
  RenderSettings settings;
  settings.method = "reference";
  settings.light_samples = kReferenceSamples;
  t.visibility = render_scene(t.scene, settings).visibility;
  return cache.emplace(name, std::move(t)).first->second;
}

class MethodRegression : public ::testing::TestWithParam<std::string> {};

TEST_P(MethodRegression, MeanErrorAgainstTheReferenceIsNoWorseThanMeasured) {
  const std::string& method = GetParam();
  double error[3];
  for (int i = 0; i < 3; ++i) {
    const Truth& t = truth(kScenes[i]);
    RenderSettings settings;
    settings.method = method;
    settings.light_samples = kLightSamples;
    const RenderResult r = render_scene(t.scene, settings);
    error[i] = mean_absolute_error(r.visibility, t.visibility);
  }
  std::printf("%-20s mean |dV| bunny %.5f, foliage %.5f, knot %.5f\n", method.c_str(), error[0], error[1], error[2]);
  const auto row = std::find_if(std::begin(kMeasured), std::end(kMeasured),
                                [&](const Measured& m) { return method == m.method; });
  if (row == std::end(kMeasured)) {
    ADD_FAILURE() << method << " has no row in kMeasured; measured now: {\"" << method << "\", " << error[0] << ", "
                  << error[1] << ", " << error[2] << "}";
    return;
  }
  const double measured[3] = {row->bunny, row->foliage, row->knot};
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE(error[i], measured[i] * kMargin)
        << method << " on " << kScenes[i] << " is worse than measured on " << kMeasuredOn << " (" << measured[i]
        << " + 25%): " << error[i];
    if (error[i] * kMargin < measured[i])
      std::printf("%s on %s: %.5f, better than measured on %s (%.5f): its bound can be tightened\n", method.c_str(),
                  kScenes[i], error[i], kMeasuredOn, measured[i]);
  }
}

INSTANTIATE_TEST_SUITE_P(Methods, MethodRegression, ::testing::ValuesIn(testing::registered_method_names()),
                         testing::method_test_name);

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
