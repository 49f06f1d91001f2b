// A light uploaded to a GPU: its GpuLight record (gpu/light_layout_shared.h) and, for a textured
// rect light (one colour channel of it, expand_textured_lights), the sampling table that channel
// follows, so the GPU draws the light points the CPU draws.
#pragma once

#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/light_layout_shared.h"
#include "penumbra/scene/light.h"

namespace penumbra::gpu {

class GpuLightBuffer {
 public:
  GpuLightBuffer(Device& device, const AreaLight& light);
  uint64_t address() const { return record_.address(); }
  const shader::GpuLight& record() const { return data_; }

 private:
  shader::GpuLight data_{};
  Buffer record_, marginal_, conditional_;
};

// The 512 floats of scene/light.h's unit_circle_table on the device (uploaded once per device).
const Buffer& unit_circle_buffer(Device& device);

}  // namespace penumbra::gpu
