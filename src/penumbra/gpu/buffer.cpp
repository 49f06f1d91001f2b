#include "penumbra/gpu/buffer.h"

#include <cstring>
#include <utility>

#include "penumbra/core/error.h"
#include "penumbra/gpu/vulkan_state.h"

namespace penumbra::gpu {
namespace {

VkBuffer as_buffer(uint64_t h) { return reinterpret_cast<VkBuffer>(h); }
VkDeviceMemory as_memory(uint64_t h) { return reinterpret_cast<VkDeviceMemory>(h); }

// A buffer and its memory, created together (the kernels' buffers and staging buffers).
struct RawBuffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
};

RawBuffer create(DeviceState& s, uint64_t bytes, VkBufferUsageFlags usage, uint32_t type, const std::string& what) {
  RawBuffer b;
  VkBufferCreateInfo bi{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bi.size = bytes;
  bi.usage = usage;
  bi.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  check(vkCreateBuffer(s.device, &bi, nullptr, &b.buffer), "vkCreateBuffer", s.info.name, " for " + what);
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(s.device, b.buffer, &req);
  if (!(req.memoryTypeBits & (1u << type))) {
    vkDestroyBuffer(s.device, b.buffer, nullptr);
    throw Error("GPU {}: no memory type can hold {}", s.info.name, what);
  }
  try {
    b.memory = s.allocate(req.size, type, what, usage & VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT);
  } catch (...) {
    vkDestroyBuffer(s.device, b.buffer, nullptr);
    throw;
  }
  vkBindBufferMemory(s.device, b.buffer, b.memory, 0);
  return b;
}

void destroy(DeviceState& s, RawBuffer b) {
  if (b.buffer) vkDestroyBuffer(s.device, b.buffer, nullptr);
  if (b.memory) vkFreeMemory(s.device, b.memory, nullptr);
}

constexpr VkBufferUsageFlags kUsage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT |
                                      VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                      VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT;

}  // namespace

Buffer::Buffer(Device& device, uint64_t bytes, std::string what) : what_(std::move(what)) {
  DeviceState& s = device.state();
  bytes = std::max<uint64_t>(16, (bytes + 15) / 16 * 16);
  const RawBuffer b = create(s, bytes, kUsage, static_cast<uint32_t>(s.memory.device_local), what_);
  device_ = &device;
  bytes_ = bytes;
  buffer_ = reinterpret_cast<uint64_t>(b.buffer);
  memory_ = reinterpret_cast<uint64_t>(b.memory);
  VkBufferDeviceAddressInfo ai{VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO};
  ai.buffer = b.buffer;
  address_ = vkGetBufferDeviceAddress(s.device, &ai);
  if (s.memory.device_local_host_visible) {
    if (vkMapMemory(s.device, b.memory, 0, VK_WHOLE_SIZE, 0, &mapped_) != VK_SUCCESS) mapped_ = nullptr;
  }
  s.allocated += bytes_;
}

Buffer::~Buffer() { release(); }

void Buffer::release() {
  if (!device_) return;
  DeviceState& s = device_->state();
  if (mapped_) vkUnmapMemory(s.device, as_memory(memory_));
  destroy(s, RawBuffer{as_buffer(buffer_), as_memory(memory_)});
  s.allocated -= bytes_;
  device_ = nullptr;
  mapped_ = nullptr;
}

Buffer::Buffer(Buffer&& o) noexcept { *this = std::move(o); }

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this == &o) return *this;
  release();
  device_ = std::exchange(o.device_, nullptr);
  bytes_ = std::exchange(o.bytes_, 0);
  buffer_ = std::exchange(o.buffer_, 0);
  memory_ = std::exchange(o.memory_, 0);
  address_ = std::exchange(o.address_, 0);
  mapped_ = std::exchange(o.mapped_, nullptr);
  what_ = std::move(o.what_);
  return *this;
}

namespace {
// A copy through a host-visible staging buffer: to the device (upload) or back.
void staged_copy(Device& device, const Buffer& target, void* host, uint64_t bytes, uint64_t offset, bool upload) {
  DeviceState& s = device.state();
  const uint32_t type = static_cast<uint32_t>(upload ? s.memory.staging : s.memory.readback);
  const RawBuffer staging = create(s, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, type,
                                   "a staging copy of " + target.what());
  VkCommandBuffer cb = VK_NULL_HANDLE;
  try {
    void* mapped = nullptr;
    check(vkMapMemory(s.device, staging.memory, 0, VK_WHOLE_SIZE, 0, &mapped), "vkMapMemory", s.info.name);
    if (upload) std::memcpy(mapped, host, bytes);
    cb = s.begin_one_time();
    VkBufferCopy region{upload ? 0 : offset, upload ? offset : 0, bytes};
    if (upload)
      vkCmdCopyBuffer(cb, staging.buffer, as_buffer(target.handle()), 1, &region);
    else
      vkCmdCopyBuffer(cb, as_buffer(target.handle()), staging.buffer, 1, &region);
    s.submit_and_wait(cb);
    if (!upload) std::memcpy(host, mapped, bytes);
    vkUnmapMemory(s.device, staging.memory);
  } catch (...) {
    if (cb) s.free_command_buffer(cb);
    destroy(s, staging);
    throw;
  }
  s.free_command_buffer(cb);
  destroy(s, staging);
}
}  // namespace

void Buffer::upload(const void* data, uint64_t bytes, uint64_t offset) {
  if (bytes == 0) return;
  if (!device_ || offset + bytes > bytes_)
    throw Error("GPU: upload of {} bytes at {} into {} of {} bytes", bytes, offset, what_, bytes_);
  if (mapped_) {
    std::memcpy(static_cast<char*>(mapped_) + offset, data, bytes);
    return;
  }
  staged_copy(*device_, *this, const_cast<void*>(data), bytes, offset, true);
}

void Buffer::download(void* data, uint64_t bytes, uint64_t offset) const {
  if (bytes == 0) return;
  if (!device_ || offset + bytes > bytes_)
    throw Error("GPU: download of {} bytes at {} from {} of {} bytes", bytes, offset, what_, bytes_);
  if (mapped_) {
    std::memcpy(data, static_cast<const char*>(mapped_) + offset, bytes);
    return;
  }
  staged_copy(*device_, *this, data, bytes, offset, false);
}

void ensure_buffer(Device& device, Buffer& buffer, uint64_t bytes, std::string what) {
  bytes = std::max<uint64_t>(bytes, 16);
  if (!buffer.empty() && buffer.bytes() >= bytes) return;
  buffer = Buffer();
  buffer = Buffer(device, bytes, std::move(what));
}

}  // namespace penumbra::gpu
