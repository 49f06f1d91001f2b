// A shadow method's GPU version (docs/gpu.md, "Porting a method"): the same name and parameter
// table as its CPU version (MethodInfo), registered beside it from its own source file
// (GpuMethodRegistration), working on the frame the GPU renderer keeps on the device
// (render/gpu_renderer.h). prepare() and evaluate() record kernels into the frame's command list;
// they never read per-pixel data back. A method that must know something only the GPU has
// before it records more (a fitted view's bounds) calls frame.flush() and reads a few bytes.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>

#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/commands.h"
#include "penumbra/gpu/device.h"
#include "penumbra/gpu/gpu_scene.h"
#include "penumbra/shadow/shadow_method.h"

namespace penumbra {

// What the renderer gives a GPU method for one light of one frame.
struct GpuFrame {
  gpu::Device* device = nullptr;
  gpu::CommandList* commands = nullptr;  // record here; the renderer submits
  const gpu::GpuScene* scene = nullptr;
  uint64_t view_samples = 0;  // GpuViewSample[slots] (shadow/view_samples_shared.h)
  uint32_t slots = 0;         // camera rays of the window: window width x height x spp
  int width = 0, height = 0;  // the whole image's
  PixelWindow window;         // the pixels rendered
  int samples_per_pixel = 1;
  uint64_t light = 0;         // the light's GpuLight (gpu/light_layout_shared.h)
  uint64_t unit_circle = 0;   // float[512]: scene/light.h unit_circle_table on the device
  // Submits what was recorded and waits; the GPU times go to the frame's.
  std::function<void()> flush;
};

// Where evaluate() writes: V per slot (the renderer sets it to 1 first) and, for a method that
// computes_irradiance(), E per slot (vec3).
struct GpuShadowOutput {
  uint64_t visibility = 0;
  uint64_t irradiance = 0;
};

class GpuShadowMethod {
 public:
  virtual ~GpuShadowMethod() = default;
  // Builds the light-space structures on the device for ctx.light (ctx.tracer is null: the
  // geometry is frame.scene). Called again only when the light or the geometry changes.
  virtual void prepare(const ShadowContext& ctx, GpuFrame& frame) = 0;
  // Records the kernels that write V (and E) for every slot of frame.view_samples.
  virtual void evaluate(const ShadowContext& ctx, GpuFrame& frame, const GpuShadowOutput& out) = 0;
  virtual bool computes_irradiance() const { return false; }
  // As ShadowMethod::keeps_prepared_after_moving (frame.scene already shows the moved objects).
  virtual bool keeps_prepared_after_moving(std::span<const uint32_t> moved_objects) { return false; }
  // Called once the frame's commands have run: reads the counters the kernels kept on the device
  // (rays traced, texels visited) into stats(). A few bytes each.
  virtual void collect_stats() {}
  MethodStats& stats() { return stats_; }

 protected:
  MethodStats stats_;
};

// A method's GPU version, registered under the CPU version's name.
struct GpuMethodInfo {
  std::string name;
  std::function<std::unique_ptr<GpuShadowMethod>(const ParamSet&)> create;
  // The device memory one instance holds for one light (as MethodInfo::estimate_memory; the
  // view samples and the scene are the renderer's). Empty: negligible.
  std::function<MemoryEstimate(const ParamSet&, const MemoryQuery&)> estimate_memory;
};

struct GpuMethodRegistration {
  explicit GpuMethodRegistration(GpuMethodInfo info);
};

// The GPU version of the method `name`, or null when it has none.
const GpuMethodInfo* find_gpu_method(const std::string& name);

// "cpu, gpu" or "cpu": the devices `name` runs on (penumbra methods).
std::string method_devices(const std::string& name);

// A method with the parameters of resolve_method_params, on the GPU. Throws a one-line Error
// naming the method when it has no GPU version.
std::unique_ptr<GpuShadowMethod> create_gpu_method(const std::string& name, const Scene& scene,
                                                   const std::vector<std::string>& overrides,
                                                   ParamSet* resolved = nullptr);

}  // namespace penumbra
