#include "penumbra/scene/json_reader.h"

#include <climits>
#include <cmath>
#include <set>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/file_util.h"

namespace penumbra {

using nlohmann::json;

std::string abbreviate_json(const json& v, size_t max_chars) {
  std::string s = v.dump(-1, ' ', false, json::error_handler_t::replace);
  if (s.size() > max_chars) s = s.substr(0, max_chars - 3) + "...";
  return s;
}

JsonValue::JsonValue(const json& value, std::string context, std::string path)
    : value_(&value), context_(std::move(context)), path_(std::move(path)) {}

std::string JsonValue::where() const { return path_.empty() ? context_ : context_ + ": " + path_; }

void JsonValue::fail(std::string_view message) const {
  throw Error("{}: {}", where(), message);
}

void JsonValue::fail_expected(std::string_view what) const {
  fail(fmt::format("expected {}, got {}", what, abbreviate_json(*value_)));
}

std::string JsonValue::child_path(std::string_view key) const {
  return path_.empty() ? std::string(key) : fmt::format("{}.{}", path_, key);
}

void JsonValue::expect_object() const {
  if (!value_->is_object()) fail_expected("an object");
}

void JsonValue::expect_object(const std::vector<std::string_view>& allowed) const {
  expect_object();
  for (const auto& [key, v] : value_->items()) {
    bool known = false;
    for (auto a : allowed) known = known || a == key;
    if (known) continue;
    std::string list;
    for (auto a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
    throw Error("{}: {}: unknown key (allowed here: {})", context_, child_path(key), list);
  }
}

bool JsonValue::has(std::string_view key) const {
  return value_->is_object() && value_->contains(key);
}

JsonValue JsonValue::operator[](std::string_view key) const {
  expect_object();
  auto it = value_->find(key);
  if (it == value_->end()) throw Error("{}: {}: required key is missing", context_, child_path(key));
  return JsonValue(*it, context_, child_path(key));
}

size_t JsonValue::size() const {
  if (!value_->is_array()) fail_expected("an array");
  return value_->size();
}

JsonValue JsonValue::at(size_t index) const {
  if (index >= size()) fail(fmt::format("index {} out of range", index));
  return JsonValue((*value_)[index], context_, fmt::format("{}[{}]", path_, index));
}

float JsonValue::number() const {
  if (!value_->is_number()) fail_expected("a number");
  double d = value_->get<double>();
  float f = static_cast<float>(d);
  // nlohmann reads 1e400 as inf; 1e39 is a finite double but overflows a float.
  if (!std::isfinite(d) || !std::isfinite(f)) fail_expected("a finite number");
  return f;
}

float JsonValue::positive() const {
  float v = value_->is_number() ? number() : 0.0f;
  if (!value_->is_number() || !(v > 0)) fail_expected("a positive number");
  return v;
}

float JsonValue::in_range(float lo, float hi) const {
  std::string what = fmt::format("a number in [{}, {}]", lo, hi);
  if (!value_->is_number()) fail_expected(what);
  float v = number();
  if (v < lo || v > hi) fail_expected(what);
  return v;
}

int JsonValue::integer(int lo, int hi) const {
  std::string what = lo == INT_MIN && hi == INT_MAX ? "an integer"
                     : hi == INT_MAX               ? fmt::format("an integer >= {}", lo)
                                                   : fmt::format("an integer in [{}, {}]", lo, hi);
  if (!value_->is_number()) fail_expected(what);
  double d = value_->get<double>();
  // Integral floats (1e3, from "leaves=1e3" on the command line) are fine; 2.5 is not.
  if (value_->is_number_float() && (!std::isfinite(d) || d != std::floor(d))) fail_expected(what);
  if (d < lo || d > hi) fail_expected(what);
  return static_cast<int>(d);
}

bool JsonValue::boolean() const {
  if (!value_->is_boolean()) fail_expected("true or false");
  return value_->get<bool>();
}

std::string JsonValue::string() const {
  if (!value_->is_string()) fail_expected("a string");
  return value_->get<std::string>();
}

std::string JsonValue::one_of(std::initializer_list<std::string_view> choices) const {
  std::string list;
  for (auto c : choices) list += (list.empty() ? "\"" : ", \"") + std::string(c) + "\"";
  std::string what = "one of " + list;
  if (!value_->is_string()) fail_expected(what);
  std::string s = value_->get<std::string>();
  for (auto c : choices)
    if (c == s) return s;
  fail_expected(what);
}

namespace {
// Reads an array of exactly n numbers, failing with `what` if the shape is wrong.
void read_numbers(const JsonValue& v, size_t n, std::string_view what, float* out) {
  const json& j = v.raw();
  if (!j.is_array() || j.size() != n) v.fail_expected(what);
  for (size_t i = 0; i < n; ++i) {
    const json& e = j[i];
    double d = e.is_number() ? e.get<double>() : NAN;
    out[i] = static_cast<float>(d);
    if (!e.is_number() || !std::isfinite(d) || !std::isfinite(out[i])) v.fail_expected(what);
  }
}
}  // namespace

Vec3f JsonValue::vec3() const {
  Vec3f v;
  read_numbers(*this, 3, "three finite numbers", &v.x);
  return v;
}

Vec3f JsonValue::direction() const {
  Vec3f v;
  read_numbers(*this, 3, "three numbers, not all zero", &v.x);
  if (!(length_squared(v) > 1e-20f) || !std::isfinite(length_squared(v)))
    fail_expected("three numbers, not all zero");
  return v;
}

Vec3f JsonValue::color() const {
  Vec3f v;
  read_numbers(*this, 3, "three non-negative numbers", &v.x);
  if (min_component(v) < 0) fail_expected("three non-negative numbers");
  return v;
}

Vec2f JsonValue::positive_vec2() const {
  Vec2f v;
  float a[2];
  read_numbers(*this, 2, "two positive numbers", a);
  if (!(a[0] > 0) || !(a[1] > 0)) fail_expected("two positive numbers");
  v.x = a[0];
  v.y = a[1];
  return v;
}

Vec3f JsonValue::positive_vec3() const {
  Vec3f v;
  read_numbers(*this, 3, "three positive numbers", &v.x);
  if (!(v.x > 0) || !(v.y > 0) || !(v.z > 0)) fail_expected("three positive numbers");
  return v;
}

float JsonValue::number_or(std::string_view key, float fallback) const {
  return has(key) ? (*this)[key].number() : fallback;
}

bool JsonValue::boolean_or(std::string_view key, bool fallback) const {
  return has(key) ? (*this)[key].boolean() : fallback;
}

// ---------------------------------------------------------------------------
// Parsing. nlohmann keeps the last of duplicate keys silently; a scene file with "size"
// written twice is almost always a mistake, so a parser callback tracks the key path and
// rejects duplicates.

json parse_json_text(std::string_view text, const std::string& name) {
  struct Level {
    bool array = false;
    size_t index = 0;
    std::string key;
    std::set<std::string> keys;
  };
  std::vector<Level> stack;
  // The key path of the value being parsed (levels [0, depth)), then `key` if given.
  auto path_of = [&stack](size_t depth, const std::string& key) {
    std::string p;
    for (size_t i = 0; i < depth; ++i)
      p += stack[i].array ? fmt::format("[{}]", stack[i].index) : (p.empty() ? "" : ".") + stack[i].key;
    return key.empty() ? p : p + (p.empty() ? "" : ".") + key;
  };
  auto element_done = [&stack] {
    if (!stack.empty() && stack.back().array) ++stack.back().index;
  };
  auto too_deep = [&] {
    if (static_cast<int>(stack.size()) >= kMaxJsonDepth)
      throw Error("{}: {}{}nested deeper than {} levels of arrays and objects", name, path_of(stack.size(), ""),
                  stack.empty() ? "" : ": ", kMaxJsonDepth);
  };
  json::parser_callback_t cb = [&](int, json::parse_event_t ev, json& parsed) {
    switch (ev) {
      case json::parse_event_t::object_start: too_deep(); stack.emplace_back(); break;
      case json::parse_event_t::array_start: too_deep(); stack.emplace_back().array = true; break;
      case json::parse_event_t::key: {
        std::string key = parsed.get<std::string>();
        if (!stack.back().keys.insert(key).second)
          throw Error("{}: {}: duplicate key", name, path_of(stack.size() - 1, key));
        stack.back().key = key;
        break;
      }
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        stack.pop_back();
        element_done();
        break;
      case json::parse_event_t::value: element_done(); break;
    }
    return true;
  };
  try {
    return json::parse(text.begin(), text.end(), cb, /*allow_exceptions=*/true,
                       /*ignore_comments=*/true);
  } catch (const json::parse_error& e) {
    // what(): "[json.exception.parse_error.101] parse error at line 3, column 7: syntax
    // error while parsing ..."; keep "line 3, column 7: ..." and name the file.
    std::string msg = e.what();
    size_t at = msg.find("at line ");
    msg = at != std::string::npos ? msg.substr(at + 3) : fmt::format("byte {}: {}", e.byte, msg);
    // One line; the bytes it quotes ("last read: '...'") as printable text where they are
    // ill-formed UTF-8 (else they would pass the bad bytes on to the terminal or a log).
    const bool bad_utf8 = msg.find("ill-formed UTF-8") != std::string::npos;
    for (char& c : msg) {
      const auto u = static_cast<unsigned char>(c);
      if (u < 32 || u == 127) c = ' ';
      else if (bad_utf8 && u >= 128) c = '?';
    }
    throw Error("{}: invalid JSON: {}", name, msg);
  } catch (const json::out_of_range& e) {
    // Numbers beyond double range (1e400): "number overflow parsing '1e400'".
    std::string msg = e.what();
    size_t q = msg.find('\'');
    std::string number = q != std::string::npos ? msg.substr(q + 1, msg.rfind('\'') - q - 1) : msg;
    std::string where = path_of(stack.size(), "");
    throw Error("{}: {}{}number out of range: {}", name, where, where.empty() ? "" : ": ", number);
  }
}

json parse_json_value_or_string(const std::string& text, const std::string& name) {
  json::parser_callback_t cb = [&](int depth, json::parse_event_t ev, json&) {
    if ((ev == json::parse_event_t::object_start || ev == json::parse_event_t::array_start) && depth >= kMaxJsonDepth)
      throw Error("{}: nested deeper than {} levels of arrays and objects", name, kMaxJsonDepth);
    return true;
  };
  json v = json::parse(text, cb, /*allow_exceptions=*/false);
  return v.is_discarded() ? json(text) : v;
}

json read_json_file(const std::filesystem::path& path) {
  return parse_json_text(read_text_file(path), path.string());
}

}  // namespace penumbra
