// penumbra methods [NAME] [--json]: the registered shadow methods and their parameters.
#include <cstdio>

#include <fmt/format.h>

#include "app/command.h"
#include "penumbra/shadow/gpu_method.h"
#include "penumbra/shadow/shadow_method.h"

namespace penumbra::app {
namespace {

// The devices a method runs on, as --device names them.
nlohmann::json devices_json(const std::string& name) {
  nlohmann::json d = {"cpu"};
  if (find_gpu_method(name)) d.push_back("gpu");
  return d;
}

int run_methods(const std::string& name, bool json) {
  std::vector<const MethodInfo*> list;
  if (name.empty()) list = MethodRegistry::all();
  else list.push_back(&MethodRegistry::get(name));
  if (json) {
    nlohmann::json out = nlohmann::json::array();
    for (const MethodInfo* m : list) {
      nlohmann::json params = nlohmann::json::array();
      for (const ParamSpec& p : m->params)
        params.push_back({{"name", p.name}, {"type", to_string(p.type)}, {"default", p.default_value},
                          {"doc", p.doc}, {"choices", p.choices}});
      out.push_back({{"name", m->name}, {"description", m->description}, {"samples_light", m->samples_light},
                     {"tile_exact", m->tile_exact}, {"sphere_through_disk", m->sphere_through_disk},
                     {"devices", devices_json(m->name)},
                     {"params", params}});
    }
    std::printf("%s\n", out.dump(2).c_str());
    return 0;
  }
  if (name.empty()) std::printf("%-20s %-9s %s\n", "method", "devices", "description");
  for (const MethodInfo* m : list) {
    std::printf("%-20s %-9s %s\n", m->name.c_str(), method_devices(m->name).c_str(), m->description.c_str());
    if (name.empty()) continue;
    if (!find_gpu_method(m->name)) std::printf("  (CPU only: --device gpu refuses it)\n");
    if (m->samples_light) std::printf("  (samples the light: --spp N sets the light samples per point)\n");
    if (!m->tile_exact)
      std::printf("  (not tile-exact: a `render --crop` window may differ from the whole frame's pixels there)\n");
    if (m->sphere_through_disk)
      std::printf("  (samples a sphere or ellipsoid light through one disk facing the scene: one that the scene reaches "
                  "behind, a bulb in a room, is drawn face by face, docs/methods/README.md)\n");
    for (const ParamSpec& p : m->params) {
      std::string extra;
      if (!p.choices.empty()) {
        extra = " {";
        for (size_t i = 0; i < p.choices.size(); ++i) extra += (i ? "|" : "") + p.choices[i];
        extra += "}";
      }
      std::printf("  %-22s %-6s = %-12s %s%s\n", p.name.c_str(), to_string(p.type), p.default_value.dump().c_str(),
                  p.doc.c_str(), extra.c_str());
    }
  }
  if (name.empty())
    std::printf("\n`penumbra methods NAME` lists a method's parameters (set with -p key=value); devices: where "
                "--device can run it (`penumbra devices` lists the GPUs).\n");
  return 0;
}

const CommandRegistration methods_command("methods", 20, [](CLI::App& app) {
  auto name = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  CLI::App* cmd = app.add_subcommand("methods", "list the shadow methods and their parameters");
  cmd->add_option("name", *name, "show one method's parameter table");
  cmd->add_flag("--json", *json, "machine-readable output");
  return [name, json] { return run_methods(*name, *json); };
});

}  // namespace
}  // namespace penumbra::app
