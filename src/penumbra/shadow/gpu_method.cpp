#include "penumbra/shadow/gpu_method.h"

#include <map>

#include "penumbra/core/error.h"

namespace penumbra {
namespace {
std::map<std::string, GpuMethodInfo>& gpu_registry() {
  static std::map<std::string, GpuMethodInfo> r;
  return r;
}
}  // namespace

GpuMethodRegistration::GpuMethodRegistration(GpuMethodInfo info) {
  std::string name = info.name;
  if (!gpu_registry().emplace(name, std::move(info)).second)
    throw Error("the GPU version of shadow method '{}' registered twice", name);
}

const GpuMethodInfo* find_gpu_method(const std::string& name) {
  auto it = gpu_registry().find(name);
  return it == gpu_registry().end() ? nullptr : &it->second;
}

std::string method_devices(const std::string& name) { return find_gpu_method(name) ? "cpu, gpu" : "cpu"; }

std::unique_ptr<GpuShadowMethod> create_gpu_method(const std::string& name, const Scene& scene,
                                                   const std::vector<std::string>& overrides, ParamSet* resolved) {
  ParamSet params = resolve_method_params(name, scene, overrides);  // also: an unknown name
  const GpuMethodInfo* gpu = find_gpu_method(name);
  if (!gpu) throw Error("{} has no GPU version yet: run it with --device cpu (`penumbra methods` lists the devices)", name);
  if (resolved) *resolved = params;
  return gpu->create(params);
}

}  // namespace penumbra
