#include "penumbra/eval/run_setup.h"

#include <gtest/gtest.h>

#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/eval/comparison.h"
#include "penumbra/shadow/shadow_method.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using nlohmann::json;

std::string scene_file(const std::string& name) { return std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name + ".json"; }

// A document with one light of each shape.
RunSetup three_lights() {
  RunSetup s;
  s.scene_path = "three.json";
  s.scene_doc = json::parse(R"({
    "camera": {"eye": [0, 4, 0.001], "target": [0, 0, 0], "up": [0, 0, -1], "resolution": [16, 8]},
    "lights": [
      {"type": "rect", "center": [0, 2, 0], "normal": [0, -1, 0], "size": [0.6, 0.8]},
      {"type": "disk", "center": [1, 2, 0], "normal": [0, -1, 0], "radius": 0.25},
      {"type": "sphere", "center": [-1, 2, 0], "radius": 0.1}
    ],
    "objects": [{"shape": "plane", "size": [4, 4]}]
  })");
  return s;
}

template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(RunSetup, RenderSettings) {
  RunSetup s = three_lights();
  s.apply("spp", "64");
  s.apply("reference_spp=512");
  s.apply("seed", "7");
  EXPECT_EQ(s.light_samples, 64);
  EXPECT_EQ(s.reference_samples, 512);
  EXPECT_EQ(s.seed, 7u);
  EXPECT_EQ(s.width(), 16);
  EXPECT_EQ(s.height(), 8);
  s.apply("resolution", "32");
  EXPECT_EQ(s.width(), 32);
  EXPECT_EQ(s.height(), 32);
  s.apply("resolution", "40x20");
  s.apply("pixel_samples", "4");
  Scene scene = s.load();
  EXPECT_EQ(scene.camera.width, 40);
  EXPECT_EQ(scene.camera.height, 20);
  EXPECT_EQ(scene.camera.samples_per_pixel, 4);
  EXPECT_EQ(s.pixel_samples(), 4);
}

TEST(RunSetup, BadValuesNameTheKey) {
  RunSetup s = three_lights();
  EXPECT_EQ(error_of([&] { s.apply("spp", "abc"); }), "spp=abc: expected an integer in [1, 1048576]");
  EXPECT_EQ(error_of([&] { s.apply("spp", "2.5"); }), "spp=2.5: expected an integer in [1, 1048576]");
  EXPECT_EQ(error_of([&] { s.apply("resolution", "12y4"); }),
            "resolution=12y4: expected N or WxH with sides in [1, 16384], e.g. 256 or 512x384");
  EXPECT_NE(error_of([&] { s.apply("resolution", "20000"); }).find("resolution=20000: expected"), std::string::npos);
  EXPECT_EQ(error_of([&] { s.apply("light.size_scale", "-1"); }), "light.size_scale=-1: expected a positive number");
  EXPECT_EQ(error_of([&] { s.apply("light.colour", "1"); }),
            "light.colour: unknown light setting (light.size_scale, light.size, light.radius)");
  EXPECT_NE(error_of([&] { s.apply("nosuchmethod.x", "1"); }).find("'nosuchmethod' is not a shadow method"),
            std::string::npos);
  EXPECT_EQ(error_of([&] { s.apply("spp"); }), "spp: expected key=value");
}

TEST(RunSetup, LightSizeScaleScalesEveryShape) {
  RunSetup s = three_lights();
  s.apply("light.size_scale", "2");
  Scene scene = s.load();
  EXPECT_FLOAT_EQ(scene.lights[0].size.x, 1.2f);
  EXPECT_FLOAT_EQ(scene.lights[0].size.y, 1.6f);
  EXPECT_FLOAT_EQ(scene.lights[1].radius, 0.5f);
  EXPECT_FLOAT_EQ(scene.lights[2].radius, 0.2f);
}

TEST(RunSetup, LightRadiusIsTheExtentRadius) {
  RunSetup s = three_lights();
  s.apply("light.radius", "0.4");
  Scene scene = s.load();
  for (const AreaLight& l : scene.lights) EXPECT_NEAR(l.extent_radius(), 0.4f, 1e-6f);
  // The rect keeps its aspect ratio: 0.6 x 0.8 has half diagonal 0.5.
  EXPECT_NEAR(scene.lights[0].size.x, 0.48f, 1e-6f);
  EXPECT_NEAR(scene.lights[0].size.y, 0.64f, 1e-6f);
}

TEST(RunSetup, LightSizeIsTheWidthOrDiameter) {
  RunSetup s = three_lights();
  s.apply("light.size", "1.2");
  Scene scene = s.load();
  EXPECT_NEAR(scene.lights[0].size.x, 1.2f, 1e-6f);
  EXPECT_NEAR(scene.lights[0].size.y, 1.6f, 1e-6f);
  EXPECT_NEAR(scene.lights[1].radius, 0.6f, 1e-6f);
  EXPECT_NEAR(scene.lights[2].radius, 0.6f, 1e-6f);
}

TEST(RunSetup, EllipsoidLightsScaleAllThreeRadii) {
  RunSetup s = three_lights();
  s.scene_doc["lights"] = json::parse(
      R"([{"type": "ellipsoid", "center": [0, 2, 0], "radii": [0.4, 0.2, 0.1], "normal": [0, -1, 0]}])");
  RunSetup scaled = s;
  scaled.apply("light.size_scale", "2");
  EXPECT_NEAR(scaled.load().lights[0].radii.y, 0.4f, 1e-6f);
  RunSetup sized = s;
  sized.apply("light.size", "1.2");  // twice the largest semi-axis
  const AreaLight l = sized.load().lights[0];
  EXPECT_NEAR(l.radii.x, 0.6f, 1e-6f);
  EXPECT_NEAR(l.radii.z, 0.15f, 1e-6f);
  RunSetup radius = s;
  radius.apply("light.radius", "0.3");
  EXPECT_NEAR(radius.load().lights[0].extent_radius(), 0.3f, 1e-6f);
}

TEST(RunSetup, GeneratorParameters) {
  RunSetup s = RunSetup::from_file(scene_file("plant"));
  s.apply("generator.leaves", "10");
  s.apply("generator.iterations", "3");
  s.apply("resolution", "8");
  Scene scene = s.load();
  size_t leaf_triangles = 0;
  for (const auto& o : scene.objects)
    if (o.name == "plant.leaves") leaf_triangles = o.mesh.triangle_count();
  EXPECT_EQ(leaf_triangles, 20u);  // 2 triangles a leaf
  EXPECT_NE(error_of([&] { s.apply("generator.petals", "3"); }).find("no generated object of the scene has a parameter 'petals'"),
            std::string::npos);
  // Type and range errors come from the scene loader, naming the key path.
  s.apply("generator.leaves", "-5");
  EXPECT_NE(error_of([&] { s.load(); }).find("params.leaves"), std::string::npos);
  RunSetup c = RunSetup::from_file(scene_file("contact"));
  EXPECT_NE(error_of([&] { c.apply("generator.leaves", "3"); }).find("generators: none"), std::string::npos);
}

TEST(RunSetup, MethodParametersPlainAndNamed) {
  RunSetup s = three_lights();
  s.apply("sampling", "area");                 // plain: every method declaring it
  s.apply("single-sample.combine", "multiply");  // named: that method only
  s.apply("reference.sampling", "solid-angle");
  EXPECT_EQ(s.overrides_for("reference"), (std::vector<std::string>{"sampling=area", "sampling=solid-angle"}));
  EXPECT_EQ(s.overrides_for("reference", /*explicit_only=*/true), (std::vector<std::string>{"sampling=solid-angle"}));
  EXPECT_EQ(s.overrides_for("single-sample"), (std::vector<std::string>{"combine=multiply"}));
  EXPECT_TRUE(s.overrides_for("hard").empty());
  // A later value of the same key replaces the earlier one (a sweep re-applies its key).
  s.apply("single-sample.combine", "add");
  EXPECT_EQ(s.overrides_for("single-sample"), (std::vector<std::string>{"combine=add"}));
  EXPECT_NO_THROW(s.check_plain_params({"hard", "reference"}));
  EXPECT_NE(error_of([&] { s.check_plain_params({"hard", "single-sample"}); })
                .find("no compared method has a parameter 'sampling'"),
            std::string::npos);
}

TEST(RunSetup, MethodSpecsCarryTheirOwnParameters) {
  MethodSpec m = parse_method_spec("single-sample:combine=add:diameter=diagonal");
  EXPECT_EQ(m.name, "single-sample");
  EXPECT_EQ(m.label, "single-sample:combine=add:diameter=diagonal");
  EXPECT_EQ(m.params, (std::vector<std::string>{"combine=add", "diameter=diagonal"}));
  EXPECT_EQ(parse_method_spec("hard").label, "hard");
  EXPECT_TRUE(parse_method_spec("hard").params.empty());
  EXPECT_NE(error_of([] { parse_method_spec("nope:x=1"); }).find("unknown shadow method 'nope'"), std::string::npos);
  EXPECT_NE(error_of([] { parse_method_spec("hard:x"); }).find("'x' is not key=value"), std::string::npos);
  // The spec's own parameters come after the run's, so they win.
  RunSetup s = three_lights();
  s.apply("single-sample.combine", "multiply");
  EXPECT_EQ(s.overrides_for(parse_method_spec("single-sample:combine=add")),
            (std::vector<std::string>{"combine=multiply", "combine=add"}));
  // A spec counts as its method for plain parameters.
  s.apply("sampling", "area");
  EXPECT_NO_THROW(s.check_plain_params({"reference:sampling=solid-angle"}));
  EXPECT_EQ(expand_method_list({"hard,single-sample:combine=add,single-sample"}),
            (std::vector<std::string>{"hard", "single-sample:combine=add", "single-sample"}));
  EXPECT_EQ(image_file_stem("pcss:variant=xie2007"), "pcss_variant=xie2007");
}

TEST(RunSetup, MethodLists) {
  EXPECT_EQ(split_list("a, b,,c "), (std::vector<std::string>{"a", "b", "c"}));
  std::vector<std::string> all = expand_method_list({"all"});
  EXPECT_EQ(all.size(), MethodRegistry::all().size());
  EXPECT_EQ(expand_method_list({"hard,reference", "hard"}), (std::vector<std::string>{"hard", "reference"}));
  EXPECT_NE(error_of([] { expand_method_list({"hard,nope"}); }).find("unknown shadow method 'nope'"), std::string::npos);
  EXPECT_THROW(expand_method_list({""}), Error);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
