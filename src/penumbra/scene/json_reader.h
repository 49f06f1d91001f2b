// Strict reading of JSON documents (scene files, generator parameters). A JsonValue is a
// view of one value that knows where it came from (the file and the key path, e.g.
// "scenes/x.json" and "lights[0].size"), so every validation error is one line naming
// both (DESIGN.md, conventions):
//   scenes/x.json: lights[0].size: expected two positive numbers, got [1,0]
// Objects are checked with expect_object(allowed keys) first, which rejects unknown keys;
// numbers are rejected unless finite as a float (JSON has no NaN, but nlohmann parses
// 1e400 as inf, and 1e39 overflows a float).
#pragma once

#include <filesystem>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/core/math.h"

namespace penumbra {

class JsonValue {
 public:
  // `context` is what messages start with (usually the file name); `path` the key path of
  // `value` inside the document ("" for the top level).
  JsonValue(const nlohmann::json& value, std::string context, std::string path = "");

  const nlohmann::json& raw() const { return *value_; }
  const std::string& path() const { return path_; }
  const std::string& context() const { return context_; }
  // "context: path" (or just the context at the top level): the start of every message.
  std::string where() const;
  [[noreturn]] void fail(std::string_view message) const;
  // "expected <what>, got <the value, abbreviated>".
  [[noreturn]] void fail_expected(std::string_view what) const;

  // --- objects and arrays
  // Throws unless this is an object whose keys are all in `allowed`.
  void expect_object(const std::vector<std::string_view>& allowed) const;
  void expect_object() const;  // any keys
  bool has(std::string_view key) const;
  // The member `key`; throws "<path>.<key>: required key is missing" if absent.
  JsonValue operator[](std::string_view key) const;
  // Array access ("lights[2]"); `size()` throws unless this is an array.
  size_t size() const;
  JsonValue at(size_t index) const;

  // --- scalars (each throws naming the path when the type or range is wrong)
  float number() const;                        // any finite float
  float positive() const;                      // > 0
  float in_range(float lo, float hi) const;    // lo <= v <= hi
  int integer(int lo, int hi) const;           // an integer (1e3 accepted, 2.5 not) in [lo, hi]
  bool boolean() const;
  std::string string() const;
  // Exactly one of `choices`.
  std::string one_of(std::initializer_list<std::string_view> choices) const;
  Vec3f vec3() const;                          // three finite numbers
  Vec3f direction() const;                     // three numbers, not all zero
  Vec3f color() const;                         // three numbers >= 0
  Vec2f positive_vec2() const;                 // two numbers > 0
  Vec3f positive_vec3() const;                 // three numbers > 0

  // --- optional members: the reader applied to the member if present, else `fallback`.
  float number_or(std::string_view key, float fallback) const;
  bool boolean_or(std::string_view key, bool fallback) const;

 private:
  std::string child_path(std::string_view key) const;
  const nlohmann::json* value_;
  std::string context_, path_;
};

// Deepest nesting of arrays and objects any penumbra JSON input may have (scene files need
// about 5): deeper text is refused while it is parsed, before anything recursive (printing a
// value for a message, destroying it) could overflow the stack.
constexpr int kMaxJsonDepth = 64;

// Parses JSON text strictly: syntax errors, duplicate keys and nesting deeper than
// kMaxJsonDepth throw one-line Errors naming `name` and the line and column
// ("scenes/x.json: line 3, column 7: syntax error ...").
nlohmann::json parse_json_text(std::string_view text, const std::string& name);
// A command-line value ("-p key=value"): its JSON when it parses as JSON (3000, 0.5, true,
// [1, 2]), else the text as a string; nesting deeper than kMaxJsonDepth throws, naming `name`.
nlohmann::json parse_json_value_or_string(const std::string& text, const std::string& name);
// Reads and parses a JSON file (errors name the file).
nlohmann::json read_json_file(const std::filesystem::path& path);

// A value abbreviated to one line of at most `max_chars` characters, for messages.
std::string abbreviate_json(const nlohmann::json& v, size_t max_chars = 40);

}  // namespace penumbra
