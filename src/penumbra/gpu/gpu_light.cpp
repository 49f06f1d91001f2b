#include "penumbra/gpu/gpu_light.h"

#include <map>
#include <mutex>

namespace penumbra::gpu {

GpuLightBuffer::GpuLightBuffer(Device& device, const AreaLight& light) {
  data_.geometry = light.geometry();
  data_.radiance = light.radiance;
  if (light.textured()) {
    const PiecewiseConstant2D& table = light.texture->table(light.texture_channel);
    marginal_ = make_buffer<float>(device, table.marginal_cdf(), "a textured light's sampling table");
    conditional_ = make_buffer<float>(device, table.conditional_cdf(), "a textured light's sampling table");
    data_.textured = 1;
    data_.marginal = marginal_.address();
    data_.conditional = conditional_.address();
    data_.table_width = table.width();
    data_.table_height = table.height();
  }
  record_ = Buffer(device, sizeof(data_), "a light");
  record_.upload(&data_, sizeof(data_));
}

const Buffer& unit_circle_buffer(Device& device) {
  static std::mutex mutex;
  static std::map<Device*, Buffer>* buffers = new std::map<Device*, Buffer>();  // lives as long as the devices
  std::lock_guard lock(mutex);
  auto it = buffers->find(&device);
  if (it != buffers->end()) return it->second;
  Buffer b(device, 512 * sizeof(float), "the unit circle's 256-gon");
  b.upload(unit_circle_table(), 512 * sizeof(float));
  return buffers->emplace(&device, std::move(b)).first->second;
}

}  // namespace penumbra::gpu
