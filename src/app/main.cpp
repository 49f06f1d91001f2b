// The penumbra command line: subcommands register from their own files (command.h).
// Every error becomes one line on stderr and a non-zero exit.
#include <algorithm>
#include <cstdio>
#include <exception>
#include <vector>

#include <fmt/format.h>

#include "app/command.h"
#include "penumbra/gpu/device.h"
#include "penumbra/core/error.h"
#include "penumbra/core/huge_pages.h"
#include "penumbra/core/interrupt.h"

namespace penumbra::app {

namespace {
struct Entry {
  std::string name;
  int order;
  CommandSetup setup;
};
std::vector<Entry>& entries() {
  static std::vector<Entry> e;
  return e;
}
}  // namespace

CommandRegistration::CommandRegistration(std::string name, int order, CommandSetup setup) {
  entries().push_back({std::move(name), order, std::move(setup)});
}

void setup_commands(CLI::App& app, std::vector<std::pair<CLI::App*, std::function<int()>>>* out) {
  auto list = entries();
  std::stable_sort(list.begin(), list.end(), [](const Entry& a, const Entry& b) { return a.order < b.order; });
  for (auto& e : list) {
    size_t before = app.get_subcommands({}).size();
    auto run = e.setup(app);
    auto subs = app.get_subcommands({});
    CLI::App* sub = subs.size() > before ? subs.back() : nullptr;
    out->push_back({sub, std::move(run)});
  }
}

}  // namespace penumbra::app

int main(int argc, char** argv) {
  // Once, before anything is allocated that matters: glibc's heap on 2 MiB pages (core/huge_pages.h).
  penumbra::reexec_with_huge_pages(argv);
  CLI::App app{"penumbra: soft shadows from area lights, five papers and their ground truth"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "penumbra 0.1.0");
  std::vector<std::pair<CLI::App*, std::function<int()>>> commands;
  penumbra::app::setup_commands(app, &commands);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  // Ctrl-C / SIGTERM: stop within a second, leave no output or temporary file (core/interrupt.h).
  penumbra::install_interrupt_handlers();
  try {
    for (auto& [sub, run] : commands)
      if (sub && sub->parsed()) {
        const int status = run();
        // Under PENUMBRA_GPU_VALIDATION any message of the Vulkan validation layers is a failure
        // (they were printed as they came): the tests run the command line that way.
        if (const uint64_t n = penumbra::gpu::validation_message_count(); n > 0 && status == 0) {
          std::fprintf(stderr, "penumbra: error: the Vulkan validation layers reported %llu problem(s)\n",
                       static_cast<unsigned long long>(n));
          return 3;
        }
        return status;
      }
  } catch (const penumbra::Interrupted&) {
    if (penumbra::claim_interrupt_message()) std::fprintf(stderr, "penumbra: error: interrupted\n");
    return 130;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra: error: %s\n", e.what());
    return 1;
  }
  return 1;
}
