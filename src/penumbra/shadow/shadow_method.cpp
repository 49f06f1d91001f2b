#include "penumbra/shadow/shadow_method.h"

#include <algorithm>
#include <map>

#include "penumbra/core/error.h"

namespace penumbra {

namespace {
std::map<std::string, MethodInfo>& registry() {
  static std::map<std::string, MethodInfo> r;
  return r;
}
}  // namespace

void MethodRegistry::add(MethodInfo info) {
  std::string name = info.name;
  if (!registry().emplace(name, std::move(info)).second)
    throw Error("shadow method '{}' registered twice", name);
}

const MethodInfo* MethodRegistry::find(const std::string& name) {
  auto it = registry().find(name);
  return it == registry().end() ? nullptr : &it->second;
}

const MethodInfo& MethodRegistry::get(const std::string& name) {
  if (const MethodInfo* m = find(name)) return *m;
  std::string known;
  for (const auto& [n, i] : registry()) known += (known.empty() ? "" : ", ") + n;
  throw Error("unknown shadow method '{}' (known: {})", name, known);
}

void MemoryTally::add(uint64_t bytes, std::string_view setting) {
  for (auto& [name, sum] : parts_)
    if (name == setting) {
      sum += bytes;
      return;
    }
  parts_.emplace_back(std::string(setting), bytes);
}

uint64_t MemoryTally::bytes() const {
  uint64_t total = 0;
  for (const auto& part : parts_) total += part.second;
  return total;
}

MemoryEstimate MemoryTally::estimate() const {
  MemoryEstimate e;
  e.bytes = bytes();
  uint64_t largest = 0;
  for (const auto& [name, sum] : parts_)
    if (e.setting.empty() || sum > largest) {
      e.setting = name;
      largest = sum;
    }
  return e;
}

std::vector<const MethodInfo*> MethodRegistry::all() {
  std::vector<const MethodInfo*> out;
  for (const auto& [n, i] : registry()) out.push_back(&i);
  return out;
}

ParamSet resolve_method_params(const std::string& name, const Scene& scene, const std::vector<std::string>& overrides) {
  const MethodInfo& info = MethodRegistry::get(name);
  ParamSet params(info.params, name);
  if (scene.method_params.is_object()) {
    for (auto it = scene.method_params.begin(); it != scene.method_params.end(); ++it) {
      if (!MethodRegistry::find(it.key()))
        throw Error("{}: methods.{}: unknown shadow method", scene.source.string(), it.key());
    }
    if (scene.method_params.contains(name))
      params.set_from_json(scene.method_params[name], fmt::format("{}: methods", scene.source.string()));
  }
  for (const std::string& kv : overrides) {
    auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) throw Error("-p {}: expected key=value", kv);
    std::string key = kv.substr(0, eq), value = kv.substr(eq + 1);
    // "method.key=value" applies to that method only (compare runs several methods).
    auto dot = key.find('.');
    if (dot != std::string::npos) {
      std::string target = key.substr(0, dot);
      if (!MethodRegistry::find(target)) throw Error("-p {}: unknown shadow method '{}'", kv, target);
      if (target != name) continue;
      key = key.substr(dot + 1);
    }
    params.set_from_string(key, value);
  }
  return params;
}

std::unique_ptr<ShadowMethod> create_method(const std::string& name, const Scene& scene,
                                            const std::vector<std::string>& overrides, ParamSet* resolved) {
  ParamSet params = resolve_method_params(name, scene, overrides);
  if (resolved) *resolved = params;
  return MethodRegistry::get(name).create(params);
}

}  // namespace penumbra
