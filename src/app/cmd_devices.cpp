// penumbra devices [--json]: the Vulkan devices --device gpu:N can name (docs/gpu.md).
#include <cstdio>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "app/command.h"
#include "penumbra/gpu/device.h"

namespace penumbra::app {
namespace {

std::string gib(uint64_t bytes) { return fmt::format("{:.1f} GiB", static_cast<double>(bytes) / (1u << 30)); }

int run_devices(bool json) {
  const std::vector<gpu::DeviceInfo> devices = gpu::list_devices();  // no loader: a one-line error
  if (json) {
    nlohmann::json out = nlohmann::json::array();
    for (const gpu::DeviceInfo& d : devices)
      out.push_back({{"device", fmt::format("gpu:{}", d.index)}, {"name", d.name}, {"type", d.type},
                     {"driver", d.driver}, {"vulkan", d.api_version}, {"memory_bytes", d.memory_bytes},
                     {"subgroup_size", d.subgroup_size}, {"usable", d.usable}, {"unusable_reason", d.unusable_reason}});
    std::printf("%s\n", out.dump(2).c_str());
    return 0;
  }
  if (devices.empty()) {
    std::printf("no Vulkan devices: --device gpu cannot run here\n");
    return 0;
  }
  for (const gpu::DeviceInfo& d : devices) {
    std::printf("gpu:%d  %s (%s), %s, Vulkan %s, %s, subgroup size %u%s\n", d.index, d.name.c_str(), d.type.c_str(),
                d.driver.c_str(), d.api_version.c_str(), gib(d.memory_bytes).c_str(), d.subgroup_size,
                d.usable ? "" : fmt::format(" - not usable: {}", d.unusable_reason).c_str());
  }
  return 0;
}

const CommandRegistration devices_command("devices", 25, [](CLI::App& app) {
  auto json = std::make_shared<bool>(false);
  CLI::App* cmd = app.add_subcommand("devices", "list the Vulkan devices --device gpu:N can name");
  cmd->add_flag("--json", *json, "machine-readable output");
  return [json] { return run_devices(*json); };
});

}  // namespace
}  // namespace penumbra::app
