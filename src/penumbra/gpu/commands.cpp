#include "penumbra/gpu/commands.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>

#include "penumbra/core/error.h"
#include "penumbra/gpu/vulkan_state.h"

namespace penumbra::gpu {
namespace {

// Timestamps per submit: with kernel profiling one a command (the largest frames record a few
// hundred commands between submits).
constexpr uint32_t kMaxQueries = 4096;
// Dispatch grids: at most this many groups along x (the least every device allows), the rest
// along y (gpu/kernel_common.glsl pn_thread_index folds them back).
constexpr uint64_t kMaxGroupsX = 65535;

VkCommandBuffer as_cb(uint64_t h) { return reinterpret_cast<VkCommandBuffer>(h); }
VkQueryPool as_pool(uint64_t h) { return reinterpret_cast<VkQueryPool>(h); }

}  // namespace

bool kernel_profiling_enabled() {
  const char* v = std::getenv("PENUMBRA_GPU_PROFILE");
  return v != nullptr && std::string_view(v) == "1";
}

double StageTimes::total() const {
  double t = 0;
  for (const auto& [name, ms] : this->ms) t += ms;
  return t;
}

void StageTimes::add(const StageTimes& o) {
  for (const auto& stage : o.ms) {
    // (Not a structured binding: clang 14, the sanitizer build's compiler, cannot capture one.)
    auto it = std::find_if(ms.begin(), ms.end(), [&](const auto& p) { return p.first == stage.first; });
    if (it == ms.end())
      ms.push_back(stage);
    else
      it->second += stage.second;
  }
  for (const KernelTime& k : o.kernels) {
    auto it = std::find_if(kernels.begin(), kernels.end(), [&](const KernelTime& x) { return x.name == k.name; });
    if (it == kernels.end()) {
      kernels.push_back(k);
    } else {
      it->ms += k.ms;
      it->dispatches += k.dispatches;
    }
  }
}

CommandList::CommandList(Device& device) : device_(&device), profile_(kernel_profiling_enabled()) {
  DeviceState& s = device.state();
  VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
  qi.queryCount = kMaxQueries;
  VkQueryPool pool = VK_NULL_HANDLE;
  check(vkCreateQueryPool(s.device, &qi, nullptr, &pool), "vkCreateQueryPool", s.info.name);
  query_pool_ = reinterpret_cast<uint64_t>(pool);
}

CommandList::~CommandList() {
  DeviceState& s = device_->state();
  // A list still recording (a frame that threw before submitting) is freed without ending it:
  // freeing a recording command buffer is valid, while ending one whose buffers are gone is not.
  if (command_buffer_) s.free_command_buffer(as_cb(command_buffer_));
  vkDestroyQueryPool(s.device, as_pool(query_pool_), nullptr);
}

void CommandList::begin_if_needed() {
  if (recording_) return;
  DeviceState& s = device_->state();
  if (command_buffer_) {
    s.free_command_buffer(as_cb(command_buffer_));
    command_buffer_ = 0;
  }
  command_buffer_ = reinterpret_cast<uint64_t>(s.begin_one_time());
  recording_ = true;
  vkCmdResetQueryPool(as_cb(command_buffer_), as_pool(query_pool_), 0, kMaxQueries);
  queries_ = 0;
  stage_names_.clear();
  command_names_.clear();
  open_command_.clear();
  if (!open_stage_.empty()) {  // a stage opened before anything was recorded
    const std::string name = open_stage_;
    open_stage_.clear();
    stage(name);
  }
}

void CommandList::stage(std::string_view name) {
  if (!recording_) {
    // Opened lazily with the command buffer (begin_if_needed).
    open_stage_ = std::string(name);
    begin_if_needed();
    return;
  }
  // Out of timestamps (one kept for submit): the open stage takes the rest.
  if (queries_ + 1 >= kMaxQueries) return;
  close_interval();
  open_stage_ = std::string(name);
  open_command_.clear();
}

void CommandList::mark(std::string_view command) {
  // Before the first stage nothing is timed (as without profiling); out of timestamps, the
  // open interval takes the rest.
  if (!profile_ || queries_ == 0 || queries_ + 1 >= kMaxQueries) return;
  close_interval();
  open_command_ = std::string(command);
}

void CommandList::close_interval() {
  vkCmdWriteTimestamp2(as_cb(command_buffer_), VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, as_pool(query_pool_), queries_);
  if (queries_ > 0) {
    stage_names_.push_back(open_stage_);
    command_names_.push_back(open_command_);
  }
  ++queries_;
}

void CommandList::barrier() {
  // Every dispatch sees the writes of those before it (shader storage, transfers, and the
  // group counts of indirect dispatches).
  VkMemoryBarrier2 mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  mb.srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT;
  mb.srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT;
  mb.dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_TRANSFER_BIT |
                    VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT;
  mb.dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
                     VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT |
                     VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT;
  VkDependencyInfo di{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  di.memoryBarrierCount = 1;
  di.pMemoryBarriers = &mb;
  vkCmdPipelineBarrier2(as_cb(command_buffer_), &di);
}

namespace {
void bind(DeviceState& s, VkCommandBuffer cb, const Kernel& kernel, const void* push, size_t bytes) {
  if (bytes > Kernel::kMaxPushBytes)
    throw Error("GPU kernel {}: {} bytes of push constants (at most {})", kernel.name, bytes, Kernel::kMaxPushBytes);
  vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, reinterpret_cast<VkPipeline>(kernel.pipeline));
  // The whole range is always pushed (zero-padded), so a kernel never reads undefined bytes.
  alignas(16) unsigned char block[Kernel::kMaxPushBytes] = {};
  if (bytes) std::memcpy(block, push, bytes);
  vkCmdPushConstants(cb, s.pipeline_layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, Kernel::kMaxPushBytes, block);
}
}  // namespace

void CommandList::dispatch(const Kernel& kernel, uint64_t threads_x, uint32_t threads_y, const void* push,
                           size_t bytes) {
  if (threads_x == 0 || threads_y == 0) return;
  begin_if_needed();
  DeviceState& s = device_->state();
  VkCommandBuffer cb = as_cb(command_buffer_);
  mark(kernel.name);
  bind(s, cb, kernel, push, bytes);
  const uint64_t gx = (threads_x + kernel.local_size[0] - 1) / kernel.local_size[0];
  const uint64_t gy = (uint64_t{threads_y} + kernel.local_size[1] - 1) / kernel.local_size[1];
  if (gx <= kMaxGroupsX) {
    if (gy > kMaxGroupsX) throw Error("GPU kernel {}: {} rows is too many", kernel.name, threads_y);
    vkCmdDispatch(cb, static_cast<uint32_t>(gx), static_cast<uint32_t>(gy), 1);
  } else {
    // A long 1D grid folded into 2D; only for 1D kernels (threads_y == 1).
    if (threads_y != 1) throw Error("GPU kernel {}: a {} x {} grid is too wide", kernel.name, threads_x, threads_y);
    const uint64_t rows = (gx + kMaxGroupsX - 1) / kMaxGroupsX;
    if (rows > kMaxGroupsX) throw Error("GPU kernel {}: {} threads is too many", kernel.name, threads_x);
    vkCmdDispatch(cb, static_cast<uint32_t>(kMaxGroupsX), static_cast<uint32_t>(rows), 1);
  }
  barrier();
}

void CommandList::dispatch_indirect(const Kernel& kernel, const Buffer& args, uint64_t offset, const void* push,
                                    size_t bytes) {
  begin_if_needed();
  DeviceState& s = device_->state();
  VkCommandBuffer cb = as_cb(command_buffer_);
  mark(kernel.name);
  bind(s, cb, kernel, push, bytes);
  vkCmdDispatchIndirect(cb, reinterpret_cast<VkBuffer>(args.handle()), offset);
  barrier();
}

void CommandList::fill(Buffer& buffer, uint32_t value, uint64_t offset, uint64_t bytes) {
  begin_if_needed();
  if (bytes == UINT64_MAX) bytes = buffer.bytes() - offset;
  if (bytes == 0) return;
  mark("fill");
  vkCmdFillBuffer(as_cb(command_buffer_), reinterpret_cast<VkBuffer>(buffer.handle()), offset, bytes, value);
  barrier();
}

void CommandList::copy(const Buffer& from, Buffer& to, uint64_t bytes, uint64_t from_offset, uint64_t to_offset) {
  if (bytes == 0) return;
  begin_if_needed();
  mark("copy");
  VkBufferCopy region{from_offset, to_offset, bytes};
  vkCmdCopyBuffer(as_cb(command_buffer_), reinterpret_cast<VkBuffer>(from.handle()),
                  reinterpret_cast<VkBuffer>(to.handle()), 1, &region);
  barrier();
}

StageTimes CommandList::submit() {
  StageTimes times;
  if (!recording_) return times;
  DeviceState& s = device_->state();
  VkCommandBuffer cb = as_cb(command_buffer_);
  if (queries_ > 0 && queries_ < kMaxQueries) close_interval();
  recording_ = false;
  open_stage_.clear();
  open_command_.clear();
  s.submit_and_wait(cb);
  if (queries_ >= 2) {
    std::vector<uint64_t> ticks(queries_);
    check(vkGetQueryPoolResults(s.device, as_pool(query_pool_), 0, queries_, ticks.size() * sizeof(uint64_t),
                                ticks.data(), sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
          "vkGetQueryPoolResults", s.info.name);
    StageTimes t;
    for (uint32_t q = 1; q < queries_; ++q) {
      const double ms = static_cast<double>(ticks[q] - ticks[q - 1]) * s.timestamp_period_ns * 1e-6;
      t.ms.emplace_back(stage_names_[q - 1], ms);
      // An interval a command opened is that command's (a stage's opening gap is no kernel's).
      if (!command_names_[q - 1].empty()) t.kernels.push_back({command_names_[q - 1], ms, 1});
    }
    times.add(t);  // merges repeated names
  }
  return times;
}

}  // namespace penumbra::gpu
