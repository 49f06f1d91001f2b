#include "penumbra/scene/generators.h"

#include <gtest/gtest.h>

#include <set>

#include "penumbra/core/file_util.h"
#include "penumbra/core/testing.h"
#include "penumbra/scene/json_reader.h"
#include "penumbra/scene/scene.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using nlohmann::json;
using test::error_message;

std::vector<SceneObject> run(const std::string& name, const json& user) {
  const GeneratorInfo& g = find_generator(name);
  return g.generate(resolve_generator_params(g, user, "test"));
}

const SceneObject& part(const std::vector<SceneObject>& parts, const std::string& name) {
  for (const auto& p : parts)
    if (p.name == name) return p;
  throw Error("no part {}", name);
}

bool same_geometry(const std::vector<SceneObject>& a, const std::vector<SceneObject>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (a[i].mesh.positions != b[i].mesh.positions || a[i].mesh.indices != b[i].mesh.indices ||
        a[i].mesh.triangle_opacity != b[i].mesh.triangle_opacity)
      return false;
  return true;
}

TEST(Generators, RegistryListsThePaperAnalogues) {
  std::vector<std::string> names;
  for (const auto& g : generators()) names.push_back(g.name);
  EXPECT_EQ(names, (std::vector<std::string>{"forest", "furball", "knot", "plant"}));  // sorted
  std::string msg = error_message([] { find_generator("teapot"); });
  EXPECT_EQ(msg, "unknown generator \"teapot\" (available: forest, furball, knot, plant)");
}

TEST(Generators, DeterministicFromSeed) {
  for (const auto& g : generators()) {
    SCOPED_TRACE(g.name);
    // Small instances keep the test fast.
    json small = g.name == "plant"    ? json{{"leaves", 200}, {"iterations", 6}}
                 : g.name == "forest" ? json{{"trees", 3}, {"leaves", 100}, {"iterations", 5}}
                 : g.name == "furball" ? json{{"strands", 100}}
                                       : json{{"segments", 64}};
    auto a = run(g.name, small), b = run(g.name, small);
    EXPECT_TRUE(same_geometry(a, b));
    bool seeded = false;
    for (const auto& p : g.params) seeded = seeded || p.name == "seed";
    if (!seeded) continue;  // the knot has no randomness
    json other = small;
    other["seed"] = 12345;
    EXPECT_FALSE(same_geometry(a, run(g.name, other)));
  }
}

TEST(Generators, PlantHonoursLeafCountAndRestsOnTheGround) {
  for (int leaves : {1, 250}) {
    auto parts = run("plant", {{"leaves", leaves}, {"iterations", 6}});
    EXPECT_EQ(part(parts, "leaves").mesh.triangle_count(), 2u * leaves);
    EXPECT_TRUE(part(parts, "leaves").material.two_sided);
  }
  auto parts = run("plant", json::object());  // defaults: 3000 leaves
  const SceneObject& stems = part(parts, "stems");
  EXPECT_EQ(part(parts, "leaves").mesh.triangle_count(), 6000u);
  EXPECT_TRUE(stems.mesh.is_closed());  // capped tubes
  EXPECT_FALSE(part(parts, "leaves").mesh.is_closed());
  Bounds3f b = stems.mesh.bounds();
  EXPECT_NEAR(b.lo.y, 0.0f, 1e-4f);
  EXPECT_NEAR(b.hi.y, 1.0f, 0.05f);  // unit height, plus the tip's radius
  EXPECT_LT(std::max(std::abs(b.lo.x), std::abs(b.hi.x)), 1.0f);
  // No leaves: the loader drops the empty part.
  EXPECT_EQ(run("plant", {{"leaves", 0}, {"iterations", 4}})[1].mesh.triangle_count(), 0u);
}

TEST(Generators, FurballHasPerStrandOpacity) {
  const int strands = 300, segments = 3;
  auto parts = run("furball", {{"strands", strands}, {"segments", segments}, {"opacity_min", 0.2}, {"opacity_max", 0.6}});
  const SceneObject& body = part(parts, "body");
  const SceneObject& hair = part(parts, "hair");
  EXPECT_TRUE(body.mesh.is_closed());
  ASSERT_TRUE(body.sphere.has_value());
  EXPECT_NEAR(body.mesh.bounds().center().y, body.sphere->center.y, 1e-5f);
  ASSERT_EQ(hair.mesh.triangle_count(), 2u * segments * strands);
  ASSERT_EQ(hair.mesh.triangle_opacity.size(), hair.mesh.triangle_count());
  EXPECT_EQ(hair.material.opacity, 1.0f);  // the convention: opacity lives per triangle
  std::set<float> distinct;
  for (size_t s = 0; s < strands; ++s) {
    float o = hair.mesh.triangle_opacity[s * 2 * segments];
    EXPECT_GE(o, 0.2f);
    EXPECT_LE(o, 0.6f);
    for (int t = 0; t < 2 * segments; ++t) EXPECT_EQ(hair.mesh.triangle_opacity[s * 2 * segments + t], o);
    distinct.insert(o);
  }
  EXPECT_GT(distinct.size(), strands / 2u);
  EXPECT_GE(hair.mesh.bounds().lo.y, -1e-4f);  // nothing below the ground
  EXPECT_NE(error_message([] { run("furball", {{"opacity_min", 0.9}, {"opacity_max", 0.1}}); }).find("opacity_min"),
            std::string::npos);
}

TEST(Generators, KnotIsAClosedTube) {
  auto parts = run("knot", {{"segments", 120}, {"sides", 8}});
  ASSERT_EQ(parts.size(), 1u);
  EXPECT_EQ(parts[0].mesh.triangle_count(), 2u * 120 * 8);
  EXPECT_TRUE(parts[0].mesh.is_closed());
  EXPECT_NEAR(parts[0].mesh.bounds().lo.y, 0.0f, 2e-3f);
  EXPECT_EQ(error_message([] { run("knot", {{"p", 3}, {"q", 6}}); }), "p and q must be coprime (got p = 3, q = 6)");
}

TEST(Generators, ParamValidation) {
  const GeneratorInfo& plant = find_generator("plant");
  json r = resolve_generator_params(plant, {{"leaves", 1e3}}, "x.json: objects[1].params");
  EXPECT_EQ(r["leaves"], 1000);
  EXPECT_TRUE(r["leaves"].is_number_integer());
  EXPECT_EQ(r["seed"], 1);  // default filled in
  EXPECT_EQ(r.size(), plant.params.size());
  EXPECT_NE(error_message([&] { resolve_generator_params(plant, {{"leaves", 2.5}}, "w"); }).find("w: leaves: expected an integer"),
            std::string::npos);
  EXPECT_NE(error_message([&] { resolve_generator_params(plant, {{"height", -1}}, "w"); }).find("w: height: expected a number in"),
            std::string::npos);
  EXPECT_NE(error_message([&] { resolve_generator_params(plant, {{"heigth", 1}}, "w"); }).find("w: heigth: unknown key"),
            std::string::npos);
  EXPECT_NE(error_message([&] { resolve_generator_params(plant, json::array(), "w"); }).find("w: expected an object"),
            std::string::npos);
}

TEST(Generators, ExampleScenesAreValidScenes) {
  for (const auto& g : generators()) {
    SCOPED_TRACE(g.name);
    json doc = make_example_scene(g.name, {});
    Scene s = parse_scene(doc, "example.json");
    EXPECT_GE(s.objects.size(), 2u);  // ground + the generated part(s)
    EXPECT_EQ(s.lights.size(), 1u);
    EXPECT_EQ(s.camera.width, 512);
  }
}

TEST(Generators, MakeExampleSceneParsesKeyValues) {
  json doc = make_example_scene("plant", {"leaves=10", "seed=7", "height=2.5", "leaves=12"});
  const json& params = doc["objects"][1]["params"];
  EXPECT_EQ(params["leaves"], 12);  // later duplicates win
  EXPECT_EQ(params["seed"], 7);
  EXPECT_EQ(params["height"], 2.5);
  Scene s = parse_scene(doc, "plant.json");
  EXPECT_EQ(s.objects.back().mesh.triangle_count(), 24u);
  EXPECT_EQ(error_message([] { make_example_scene("plant", {"leaves=many"}); }),
            "scene plant: leaves: expected an integer in [0, 1000000], got \"many\"");
  EXPECT_EQ(error_message([] { make_example_scene("plant", {"leaves"}); }), "--param leaves: expected key=value");
  EXPECT_NE(error_message([] { make_example_scene("plant", {"colour=red"}); }).find("scene plant: colour: unknown key"),
            std::string::npos);
  EXPECT_NE(error_message([] { make_example_scene("vase", {}); }).find("unknown generator"), std::string::npos);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// docs/scene-format.md documents every generator parameter (a new one must be added there).
TEST(Generators, EveryParameterIsDocumented) {
  std::string doc = read_text_file(std::filesystem::path(PENUMBRA_SOURCE_DIR) / "docs" / "scene-format.md");
  for (const auto& g : generators()) {
    EXPECT_NE(doc.find("### `" + g.name + "`"), std::string::npos) << g.name;
    for (const auto& p : g.params)
      EXPECT_NE(doc.find("| `" + p.name + "` |"), std::string::npos) << g.name << "." << p.name;
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
