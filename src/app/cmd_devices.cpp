// penumbra devices [--json]: the Vulkan devices --device gpu:N can name (docs/gpu.md);
// --compile: every embedded kernel compiled on one of them, each timed (a driver that takes long
// over one kernel is found here, not inside a render).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "app/command.h"
#include "penumbra/core/error.h"
#include "penumbra/gpu/device.h"
#include "penumbra/gpu/shaders.h"

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

// Builds the pipeline of every embedded kernel on `device`, one at a time, and says how long each
// took (the name is printed before its pipeline is built, so a driver that hangs on one names it).
int compile_kernels(const std::string& device, bool json) {
  const gpu::DeviceChoice choice = gpu::DeviceChoice::parse(device);
  if (!choice.gpu) throw Error("devices --compile: --device {} has no kernels to compile (name gpu or gpu:N)", device);
  gpu::Device& d = gpu::Device::get(choice);
  struct Compiled {
    std::string name;
    double ms;
  };
  std::vector<Compiled> times;
  double total = 0;
  if (!json) std::printf("compiling %zu kernels on %s\n", gpu::spirv_modules().size(), d.info().name.c_str());
  for (const gpu::SpirvModule& m : gpu::spirv_modules()) {
    if (!json) {
      std::printf("%-40s ", std::string(m.name).c_str());
      std::fflush(stdout);
    }
    const auto start = std::chrono::steady_clock::now();
    d.kernel(m.name);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    total += ms;
    times.push_back({std::string(m.name), ms});
    if (!json) std::printf("%10.1f ms\n", ms);
  }
  std::stable_sort(times.begin(), times.end(), [](const Compiled& a, const Compiled& b) { return a.ms > b.ms; });
  if (json) {
    nlohmann::json out = {{"device", d.info().name}, {"driver", d.info().driver}, {"total_ms", total}};
    nlohmann::json kernels = nlohmann::json::array();
    for (const Compiled& c : times) kernels.push_back({{"kernel", c.name}, {"ms", c.ms}});
    out["kernels"] = kernels;
    std::printf("%s\n", out.dump(2).c_str());
    return 0;
  }
  std::printf("%zu kernels in %.1f ms; the slowest:", times.size(), total);
  for (size_t i = 0; i < std::min<size_t>(5, times.size()); ++i)
    std::printf("%s %s %.1f ms", i == 0 ? "" : ",", times[i].name.c_str(), times[i].ms);
  std::printf("\n");
  return 0;
}

struct DevicesOptions {
  bool json = false;
  bool compile = false;
  std::string device = "gpu";
};

const CommandRegistration devices_command("devices", 25, [](CLI::App& app) {
  auto o = std::make_shared<DevicesOptions>();
  CLI::App* cmd = app.add_subcommand("devices", "list the Vulkan devices --device gpu:N can name");
  cmd->add_flag("--json", o->json, "machine-readable output");
  cmd->add_flag("--compile", o->compile,
                "compile every kernel on --device and time each (a driver slow on one kernel is found here)");
  cmd->add_option("--device", o->device, "with --compile: the device (gpu or gpu:N)")->capture_default_str();
  return [o] { return o->compile ? compile_kernels(o->device, o->json) : run_devices(o->json); };
});

}  // namespace
}  // namespace penumbra::app
