#include "penumbra/scene/json_reader.h"

#include <gtest/gtest.h>

#include "penumbra/core/testing.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using nlohmann::json;
using test::error_message;

TEST(JsonValue, PathsInMessages) {
  json d = json::parse(R"({"a": {"b": [1, 2.5, "x", true]}})");
  JsonValue root(d, "f.json");
  JsonValue b = root["a"]["b"];
  EXPECT_EQ(b.path(), "a.b");
  EXPECT_EQ(b.at(1).path(), "a.b[1]");
  EXPECT_EQ(b.at(0).integer(0, 10), 1);
  EXPECT_EQ(error_message([&] { b.at(1).integer(0, 10); }), "f.json: a.b[1]: expected an integer in [0, 10], got 2.5");
  EXPECT_EQ(error_message([&] { b.at(2).number(); }), "f.json: a.b[2]: expected a number, got \"x\"");
  EXPECT_EQ(error_message([&] { b.at(3).number(); }), "f.json: a.b[3]: expected a number, got true");
  EXPECT_EQ(error_message([&] { root["a"]["c"]; }), "f.json: a.c: required key is missing");
  EXPECT_EQ(error_message([&] { root.expect_object({"b"}); }), "f.json: a: unknown key (allowed here: b)");
  EXPECT_EQ(error_message([&] { b.at(9); }), "f.json: a.b: index 9 out of range");
}

TEST(JsonValue, NumbersMustBeFiniteFloats) {
  json d = {{"big", 1e39}, {"ok", 1e38}, {"int", 1e3}};
  JsonValue v(d, "f.json");
  EXPECT_EQ(error_message([&] { v["big"].number(); }), "f.json: big: expected a finite number, got 1e+39");
  EXPECT_FLOAT_EQ(v["ok"].number(), 1e38f);
  EXPECT_EQ(v["int"].integer(0, 5000), 1000);  // an integral float is an integer
}

TEST(JsonText, NestingIsLimitedWhileParsing) {
  const auto nested = [](int levels) { return std::string(levels, '[') + std::string(levels, ']'); };
  EXPECT_NO_THROW(parse_json_text(nested(kMaxJsonDepth), "f.json"));
  EXPECT_EQ(error_message([&] { parse_json_text(nested(kMaxJsonDepth + 1), "f.json"); }),
            "f.json: [0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0]"
            "[0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0][0]: nested "
            "deeper than 64 levels of arrays and objects");
  EXPECT_NE(error_message([&] { parse_json_text(R"({"camera": )" + nested(100000) + "}", "f.json"); })
                .find("f.json: camera[0]"),
            std::string::npos);
  // Command-line values: JSON where they parse, else strings, and never deeper than the limit.
  EXPECT_EQ(parse_json_value_or_string("[1, 2]", "--param x"), json::array({1, 2}));
  EXPECT_EQ(parse_json_value_or_string("abc", "--param x"), json("abc"));
  EXPECT_EQ(error_message([&] { parse_json_value_or_string(nested(100000), "--param x"); }),
            "--param x: nested deeper than 64 levels of arrays and objects");
}

TEST(JsonValue, LongValuesAreAbbreviated) {
  json big = json::array();
  for (int i = 0; i < 100; ++i) big.push_back(i);
  std::string s = abbreviate_json(big);
  EXPECT_EQ(s.size(), 40u);
  EXPECT_EQ(s.substr(37), "...");
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
