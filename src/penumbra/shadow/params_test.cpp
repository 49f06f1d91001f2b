#include "penumbra/shadow/params.h"

#include <gtest/gtest.h>

#include "penumbra/core/error.h"
#include "penumbra/shadow/shadow_method.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

std::vector<ParamSpec> specs() {
  return {{"samples", ParamType::Int, 64, "light samples", {}, 1, 4096},
          {"epsilon", ParamType::Float, 0.01, "depth tolerance", {}, 0, 1},
          {"bilinear", ParamType::Bool, true, "filter"},
          {"mode", ParamType::String, "min", "rule", {"min", "max"}}};
}

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ParamSet, DefaultsThenTypedValues) {
  ParamSet p(specs(), "lam");
  EXPECT_EQ(p.get_int("samples"), 64);
  p.set_from_string("samples", "256");
  p.set_from_string("epsilon", "0.5");
  p.set_from_string("bilinear", "off");
  p.set_from_string("mode", "max");
  EXPECT_EQ(p.get_int("samples"), 256);
  EXPECT_FLOAT_EQ(p.get_float("epsilon"), 0.5f);
  EXPECT_FALSE(p.get_bool("bilinear"));
  EXPECT_EQ(p.get_string("mode"), "max");
  p.set_from_json({{"samples", 16}, {"epsilon", 1}}, "scene.json: methods");
  EXPECT_EQ(p.get_int("samples"), 16);
  EXPECT_FLOAT_EQ(p.get_float("epsilon"), 1.0f);
}

TEST(ParamSet, BadValuesNameTheMethodKeyAndValue) {
  ParamSet p(specs(), "lam");
  EXPECT_NE(message_of([&] { p.set_from_string("sample", "3"); }).find("unknown parameter 'sample'"), std::string::npos);
  EXPECT_NE(message_of([&] { p.set_from_string("samples", "3.5"); }).find("lam.samples"), std::string::npos);
  EXPECT_NE(message_of([&] { p.set_from_string("samples", "0"); }).find("outside"), std::string::npos);
  EXPECT_NE(message_of([&] { p.set_from_string("epsilon", "abc"); }).find("'abc'"), std::string::npos);
  EXPECT_NE(message_of([&] { p.set_from_string("bilinear", "maybe"); }).find("bool"), std::string::npos);
  EXPECT_NE(message_of([&] { p.set_from_string("epsilon", "nan"); }).find("finite number, got nan"), std::string::npos);
  EXPECT_NE(message_of([&] { p.set_from_string("epsilon", "inf"); }).find("finite number, got inf"), std::string::npos);
  EXPECT_NE(message_of([&] { p.set_from_string("mode", "avg"); }).find("not one of min, max"), std::string::npos);
  EXPECT_NE(message_of([&] { p.set_from_json({{"samples", "many"}}, "x.json: methods"); }).find("x.json: methods"),
            std::string::npos);
  EXPECT_EQ(p.get_int("samples"), 64);  // nothing was half-applied
}

TEST(MethodRegistry, SceneDefaultsThenCommandLineOverrides) {
  Scene scene;
  scene.source = "s.json";
  scene.method_params = {{"reference", {{"sampling", "area"}}}};
  ParamSet resolved;
  create_method("reference", scene, {}, &resolved);
  EXPECT_EQ(resolved.get_string("sampling"), "area");
  create_method("reference", scene, {"sampling=solid-angle"}, &resolved);
  EXPECT_EQ(resolved.get_string("sampling"), "solid-angle");
  // "method.key=value" applies to that method only.
  create_method("reference", scene, {"hard.nothing=1", "reference.sampling=solid-angle"}, &resolved);
  EXPECT_EQ(resolved.get_string("sampling"), "solid-angle");
  EXPECT_THROW(create_method("reference", scene, {"nope.x=1"}, &resolved), Error);
  EXPECT_THROW(create_method("reference", scene, {"sampling"}, &resolved), Error);
  scene.method_params = {{"no-such-method", nlohmann::json::object()}};
  EXPECT_NE(message_of([&] { create_method("reference", scene, {}); }).find("s.json: methods.no-such-method"),
            std::string::npos);
  EXPECT_NE(message_of([&] { create_method("nope", Scene{}, {}); }).find("known: "), std::string::npos);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
