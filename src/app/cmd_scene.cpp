// penumbra scene NAME [--param k=v]... -o scene.json: a ready-to-render scene around a
// procedural generator (ground plane, camera, rect light). `penumbra scene --list` lists
// the generators and their parameters.
#include <cstdio>

#include "app/command.h"
#include "app/common.h"
#include "penumbra/core/file_util.h"
#include "penumbra/scene/generators.h"

namespace penumbra::app {
namespace {

struct SceneOptions {
  std::string name, output;
  std::vector<std::string> params;
  bool list = false;
};

int run_scene(const SceneOptions& o) {
  if (o.list || o.name.empty()) {
    for (const GeneratorInfo& g : generators()) {
      std::printf("%-10s %s\n", g.name.c_str(), g.description.c_str());
      for (const GeneratorParam& p : g.params)
        std::printf("  %-16s = %-10s %s\n", p.name.c_str(), p.default_value.dump().c_str(), p.doc.c_str());
    }
    if (!o.list) throw Error("scene: name a generator (see the list above)");
    return 0;
  }
  if (o.output.empty()) throw Error("scene {}: -o FILE.json is required", o.name);
  check_output_path(o.output, {".json"});
  nlohmann::json doc = make_example_scene(o.name, o.params);
  write_text_file_atomic(o.output, doc.dump(2) + "\n");
  return 0;
}

const CommandRegistration scene_command("scene", 30, [](CLI::App& app) {
  auto o = std::make_shared<SceneOptions>();
  CLI::App* cmd = app.add_subcommand("scene", "write a ready scene file around a procedural generator");
  cmd->add_option("name", o->name, "generator: plant, furball, knot");
  cmd->add_option("--param", o->params, "generator parameter key=value (repeatable)");
  cmd->add_option("-o,--output", o->output, "scene file to write (.json)");
  cmd->add_flag("--list", o->list, "list the generators and their parameters");
  return [o] { return run_scene(*o); };
});

}  // namespace
}  // namespace penumbra::app
