// Recording and running kernels: a CommandList records dispatches (each followed by a barrier,
// so every dispatch sees what the previous ones wrote), fills and copies, with named stages
// timed by timestamp queries, then submits them once and waits. Host code orchestrates this
// way and measures; it never computes per pixel.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/device.h"

namespace penumbra::gpu {

// A compute pipeline compiled from one embedded SPIR-V module (Device::kernel). Every kernel
// takes up to kMaxPushBytes of push constants (its parameters and its buffers' addresses) and
// no descriptor sets.
class Kernel {
 public:
  static constexpr uint32_t kMaxPushBytes = 128;  // the least every Vulkan device offers
  std::string name;
  uint32_t local_size[3] = {1, 1, 1};  // read from the module (LocalSize or LocalSizeId)
  uint64_t pipeline = 0;               // VkPipeline
};

// GPU time of one kernel over a frame: its dispatches (fills and copies under "fill", "copy"),
// each timed from its start to the next command's (its barrier included).
struct KernelTime {
  std::string name;
  double ms = 0;
  uint64_t dispatches = 0;
};

// GPU time per stage, in the order the stages were first opened; with kernel profiling
// (kernel_profiling_enabled), also per kernel.
struct StageTimes {
  std::vector<std::pair<std::string, double>> ms;
  std::vector<KernelTime> kernels;  // empty without kernel profiling
  double total() const;
  void add(const StageTimes& o);  // sums stages (and kernels) of the same name
};

// Kernel profiling: a timestamp before every command, so StageTimes also says where each stage's
// time goes, kernel by kernel (issue 31: Nsight Compute does not read Vulkan compute dispatches).
// On when the environment holds PENUMBRA_GPU_PROFILE=1 as a CommandList is made. The stages'
// times stay what they are without it, but for the timestamps' own small cost.
bool kernel_profiling_enabled();

class CommandList {
 public:
  explicit CommandList(Device& device);
  ~CommandList();
  CommandList(const CommandList&) = delete;
  CommandList& operator=(const CommandList&) = delete;

  Device& device() { return *device_; }

  // From here to the next stage() (or submit) GPU time counts toward `name`.
  void stage(std::string_view name);

  // `kernel` over a grid of threads (not groups): x is split over a second grid dimension
  // where it needs more than 65535 groups (GLSL: pn_thread_index() in gpu/kernel_common.glsl).
  // `push` is copied into the push constants (at most Kernel::kMaxPushBytes).
  void dispatch(const Kernel& kernel, uint64_t threads_x, uint32_t threads_y, const void* push, size_t bytes);
  template <class Push>
  void dispatch(std::string_view kernel, uint64_t threads, const Push& push) {
    static_assert(sizeof(Push) <= Kernel::kMaxPushBytes, "push constants over 128 bytes");
    dispatch(device_->kernel(kernel), threads, 1, &push, sizeof(Push));
  }
  template <class Push>
  void dispatch_2d(std::string_view kernel, uint32_t threads_x, uint32_t threads_y, const Push& push) {
    static_assert(sizeof(Push) <= Kernel::kMaxPushBytes, "push constants over 128 bytes");
    dispatch(device_->kernel(kernel), threads_x, threads_y, &push, sizeof(Push));
  }
  // `kernel` over the group counts a kernel wrote into `args` at `offset` (three uint32: x, y,
  // z groups; VkDispatchIndirectCommand): work whose size only the GPU knows.
  template <class Push>
  void dispatch_indirect(std::string_view kernel, const Buffer& args, uint64_t offset, const Push& push) {
    static_assert(sizeof(Push) <= Kernel::kMaxPushBytes, "push constants over 128 bytes");
    dispatch_indirect(device_->kernel(kernel), args, offset, &push, sizeof(Push));
  }
  void dispatch_indirect(const Kernel& kernel, const Buffer& args, uint64_t offset, const void* push, size_t bytes);

  // Every 32-bit word of [offset, offset + bytes) of `buffer` set to `value` (bytes: a multiple
  // of 4; UINT64_MAX = to the end).
  void fill(Buffer& buffer, uint32_t value, uint64_t offset = 0, uint64_t bytes = UINT64_MAX);
  void copy(const Buffer& from, Buffer& to, uint64_t bytes, uint64_t from_offset = 0, uint64_t to_offset = 0);

  // Submits what was recorded, waits for it, and returns the GPU time of each stage. The list
  // is empty afterwards and can record again.
  StageTimes submit();

 private:
  void begin_if_needed();
  void barrier();
  // Kernel profiling: a timestamp that closes the open interval and opens one for `command`.
  void mark(std::string_view command);
  // A timestamp that ends the open interval (after the first), named by the open stage and command.
  void close_interval();
  Device* device_;
  uint64_t command_buffer_ = 0;  // VkCommandBuffer
  uint64_t query_pool_ = 0;      // VkQueryPool
  uint32_t queries_ = 0;         // timestamps written so far
  std::vector<std::string> stage_names_;  // per timestamp after the first: the stage it closes
  std::vector<std::string> command_names_;  // the same, the command it closes ("" none; profiling)
  std::string open_stage_;
  std::string open_command_;
  bool profile_ = false;
  bool recording_ = false;
};

}  // namespace penumbra::gpu
