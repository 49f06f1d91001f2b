// Inside the device layer only (gpu/*.cpp): the Vulkan objects behind a Device, and the checks
// that turn a failed Vulkan call into a one-line Error. Nothing outside src/penumbra/gpu/
// includes this file.
#pragma once

#include <volk.h>

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "penumbra/gpu/commands.h"
#include "penumbra/gpu/device.h"

namespace penumbra::gpu {

const char* result_name(VkResult result);

// Throws Error "GPU <device>: <call> failed (<VkResult>)<context>" unless result is VK_SUCCESS.
void check(VkResult result, const char* call, const std::string& device_name, const std::string& context = {});

// The memory types a device's buffers use (chosen once per device from its memory properties).
struct MemoryTypes {
  int device_local = -1;  // kernels' buffers: the largest device-local heap's
  bool device_local_host_visible = false;  // that type can be mapped (no staging needed)
  int staging = -1;       // host-visible and coherent: uploads (write-combined on a discrete card)
  int readback = -1;      // host-visible, coherent and cached, else `staging`: downloads (the CPU
                          // reads write-combined memory at a fraction of its speed)
};
// Kernels' buffers in the device-local type of the heap of `device_heap_bytes` (host-visible too
// on unified memory, `unified`: a CPU driver or an integrated GPU, where no staging copy is
// needed; never a discrete card's BAR window, which the host reads uncached). -1 where none.
MemoryTypes choose_memory_types(const VkPhysicalDeviceMemoryProperties& mem, uint64_t device_heap_bytes, bool unified);

struct DeviceState {
  DeviceInfo info;
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t queue_family = 0;
  VkCommandPool command_pool = VK_NULL_HANDLE;  // guarded by mutex
  VkPipelineLayout pipeline_layout = VK_NULL_HANDLE;  // push constants only, shared by every kernel
  MemoryTypes memory;  // the types of kernels' buffers, uploads and downloads (all found: checked at creation)
  uint64_t heap_bytes = 0;
  double timestamp_period_ns = 1;
  std::atomic<uint64_t> allocated{0};
  std::mutex mutex;  // the queue, the command pool and the kernel table
  std::map<std::string, std::unique_ptr<Kernel>, std::less<>> kernels;

  // vkAllocateMemory of `bytes` of memory type `type`, through the failure hook; `what` and
  // the size name it in the error.
  VkDeviceMemory allocate(uint64_t bytes, uint32_t type, const std::string& what, bool device_address);
  // vkQueueSubmit of one command buffer, then a wait for it (through the failure hook).
  void submit_and_wait(VkCommandBuffer cb);
  VkCommandBuffer begin_one_time();
  void free_command_buffer(VkCommandBuffer cb);
};

}  // namespace penumbra::gpu
