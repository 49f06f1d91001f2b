#include "penumbra/shadow/params.h"

#include <cmath>

#include <fmt/format.h>

#include "penumbra/core/error.h"

namespace penumbra {

const char* to_string(ParamType t) {
  switch (t) {
    case ParamType::Int: return "int";
    case ParamType::Float: return "float";
    case ParamType::Bool: return "bool";
    case ParamType::String: return "string";
  }
  return "?";
}

ParamSet::ParamSet(std::vector<ParamSpec> specs, std::string context)
    : specs_(std::move(specs)), context_(std::move(context)) {
  for (const auto& s : specs_) values_[s.name] = s.default_value;
}

const ParamSpec& ParamSet::spec(const std::string& key, const std::string& where) const {
  for (const auto& s : specs_)
    if (s.name == key) return s;
  std::string known;
  for (const auto& s : specs_) known += (known.empty() ? "" : ", ") + s.name;
  throw Error("{}{}: unknown parameter '{}' (known: {})", where.empty() ? "" : where + ": ", context_, key,
              known.empty() ? "none" : known);
}

void ParamSet::set(const std::string& key, const nlohmann::json& value, const std::string& where) {
  const ParamSpec& s = spec(key, where);
  std::string at = fmt::format("{}{}.{}", where.empty() ? "" : where + ": ", context_, key);
  nlohmann::json v;
  switch (s.type) {
    case ParamType::Int:
      // (A float beyond the range of long long would overflow the conversion below.)
      if (!value.is_number_integer() &&
          !(value.is_number_float() && std::floor(value.get<double>()) == value.get<double>() &&
            std::abs(value.get<double>()) < 9.2e18))
        throw Error("{}: expected an integer, got {}", at, value.dump());
      v = value.get<long long>();
      break;
    case ParamType::Float:
      if (!value.is_number() || !std::isfinite(value.get<double>()))
        // JSON has no NaN or infinity (dump() would print "null"): show the number itself.
        throw Error("{}: expected a finite number, got {}", at,
                    value.is_number() ? fmt::format("{}", value.get<double>()) : value.dump());
      v = value.get<double>();
      break;
    case ParamType::Bool:
      if (!value.is_boolean()) throw Error("{}: expected true or false, got {}", at, value.dump());
      v = value;
      break;
    case ParamType::String:
      if (!value.is_string()) throw Error("{}: expected a string, got {}", at, value.dump());
      v = value;
      if (!s.choices.empty() &&
          std::find(s.choices.begin(), s.choices.end(), value.get<std::string>()) == s.choices.end()) {
        std::string list;
        for (const auto& c : s.choices) list += (list.empty() ? "" : ", ") + c;
        throw Error("{}: '{}' is not one of {}", at, value.get<std::string>(), list);
      }
      break;
  }
  if (s.type == ParamType::Int || s.type == ParamType::Float) {
    double d = v.get<double>();
    if (d < s.min || d > s.max) throw Error("{}: {} is outside [{}, {}]", at, value.dump(), s.min, s.max);
  }
  values_[key] = v;
}

void ParamSet::set_from_json(const nlohmann::json& obj, const std::string& where) {
  if (!obj.is_object()) throw Error("{}: expected an object of parameters for {}", where, context_);
  for (auto it = obj.begin(); it != obj.end(); ++it) set(it.key(), it.value(), where);
}

void ParamSet::set_from_string(const std::string& key, const std::string& text) {
  const ParamSpec& s = spec(key, "");
  std::string at = fmt::format("{}.{}", context_, key);
  nlohmann::json v;
  try {
    switch (s.type) {
      case ParamType::Int: {
        size_t pos;
        long long x = std::stoll(text, &pos);
        if (pos != text.size()) throw std::invalid_argument(text);
        v = x;
        break;
      }
      case ParamType::Float: {
        size_t pos;
        double x = std::stod(text, &pos);
        if (pos != text.size()) throw std::invalid_argument(text);
        v = x;
        break;
      }
      case ParamType::Bool:
        if (text == "true" || text == "1" || text == "on" || text == "yes") v = true;
        else if (text == "false" || text == "0" || text == "off" || text == "no") v = false;
        else throw std::invalid_argument(text);
        break;
      case ParamType::String:
        v = text;
        break;
    }
  } catch (const std::logic_error&) {
    throw Error("{}: cannot read '{}' as {}", at, text, to_string(s.type));
  }
  set(key, v, "");
}

int ParamSet::get_int(const std::string& key) const { return static_cast<int>(values_.at(key).get<long long>()); }
float ParamSet::get_float(const std::string& key) const { return static_cast<float>(values_.at(key).get<double>()); }
bool ParamSet::get_bool(const std::string& key) const { return values_.at(key).get<bool>(); }
const std::string& ParamSet::get_string(const std::string& key) const {
  return values_.at(key).get_ref<const std::string&>();
}

nlohmann::json ParamSet::to_json() const {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [k, v] : values_) j[k] = v;
  return j;
}

}  // namespace penumbra
