// Device memory for kernels: a storage buffer that kernels reach through its device address
// (GLSL buffer_reference, scalar layout; the layouts are the *_shared.h headers'). One
// allocation per buffer: penumbra holds tens of buffers per render, not thousands.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "penumbra/gpu/device.h"

namespace penumbra::gpu {

class Buffer {
 public:
  Buffer() = default;
  // `bytes` of device-local memory (at least 16); `what` names it in errors ("the BVH nodes").
  // Throws Error naming `what` and the size when the device cannot allocate it.
  Buffer(Device& device, uint64_t bytes, std::string what);
  ~Buffer();
  Buffer(Buffer&& o) noexcept;
  Buffer& operator=(Buffer&& o) noexcept;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  bool empty() const { return device_ == nullptr; }
  uint64_t bytes() const { return bytes_; }
  uint64_t address() const { return address_; }  // what a kernel's buffer reference takes
  const std::string& what() const { return what_; }

  // Host <-> device copies, synchronous (through a staging buffer where the memory is not
  // host-visible). Must not overlap a submission still running that uses the buffer: every
  // CommandList::submit waits, so between submissions they never do.
  void upload(const void* data, uint64_t bytes, uint64_t offset = 0);
  void download(void* data, uint64_t bytes, uint64_t offset = 0) const;
  template <class T>
  void upload(std::span<const T> values, uint64_t offset = 0) {
    upload(values.data(), values.size_bytes(), offset);
  }
  template <class T>
  std::vector<T> download_vector(size_t count, uint64_t offset = 0) const {
    std::vector<T> out(count);
    download(out.data(), count * sizeof(T), offset);
    return out;
  }

  // Vulkan handles, for the device layer's own use (commands.cpp).
  uint64_t handle() const { return buffer_; }

 private:
  void release();
  Device* device_ = nullptr;
  uint64_t bytes_ = 0;
  uint64_t buffer_ = 0;  // VkBuffer
  uint64_t memory_ = 0;  // VkDeviceMemory
  uint64_t address_ = 0;
  void* mapped_ = nullptr;  // where the memory is host-visible (lavapipe, unified memory)
  std::string what_;
};

// A buffer of `count` values of T, filled from `values` (empty: left undefined).
// Makes `buffer` hold at least `bytes` (at least 16): an empty or smaller one is released first
// (so the old and the new never hold memory together) and replaced, its contents lost; one large
// enough is kept as it is. Call it only where no recorded kernel still reads the old buffer.
void ensure_buffer(Device& device, Buffer& buffer, uint64_t bytes, std::string what);

template <class T>
Buffer make_buffer(Device& device, std::span<const T> values, std::string what) {
  Buffer b(device, std::max<uint64_t>(16, values.size_bytes()), std::move(what));
  if (!values.empty()) b.upload(values);
  return b;
}

}  // namespace penumbra::gpu
