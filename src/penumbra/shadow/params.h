// Typed, documented method parameters (the Mitsuba plugin parameter table): each method
// declares its table; values come from defaults, the scene file's "methods" section and
// the CLI's -p key=value, in that order, and are validated against the table.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace penumbra {

enum class ParamType { Int, Float, Bool, String };

struct ParamSpec {
  std::string name;
  ParamType type = ParamType::Float;
  nlohmann::json default_value;
  std::string doc;
  std::vector<std::string> choices;  // String parameters: the allowed values (empty = any)
  double min = -1e300, max = 1e300;  // Int/Float: the allowed range (inclusive)
};

class ParamSet {
 public:
  ParamSet() = default;
  // Defaults from `specs`; `context` names the method in messages.
  ParamSet(std::vector<ParamSpec> specs, std::string context);
  // Sets from a JSON object (scene file): unknown keys and wrong types throw, naming
  // `where` and the key.
  void set_from_json(const nlohmann::json& obj, const std::string& where);
  // Sets from "key=value" text (CLI): the value is parsed by the parameter's type.
  void set_from_string(const std::string& key, const std::string& value);
  void set(const std::string& key, const nlohmann::json& value, const std::string& where = "");

  int get_int(const std::string& key) const;
  float get_float(const std::string& key) const;
  bool get_bool(const std::string& key) const;
  const std::string& get_string(const std::string& key) const;
  bool has(const std::string& key) const { return values_.count(key) != 0; }
  const std::vector<ParamSpec>& specs() const { return specs_; }
  nlohmann::json to_json() const;

 private:
  const ParamSpec& spec(const std::string& key, const std::string& where) const;
  std::vector<ParamSpec> specs_;
  std::string context_;
  std::map<std::string, nlohmann::json> values_;
};

const char* to_string(ParamType t);

}  // namespace penumbra
