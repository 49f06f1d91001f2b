// The GPU device layer (docs/gpu.md): Vulkan 1.3 compute, loaded at run time (volk), no
// window and no graphics queue. This folder is the only place in penumbra that calls Vulkan;
// methods and the renderer use the types below (Device, Buffer, Kernel, CommandList) and
// never see a Vulkan handle.
//
// What a device must have (DeviceInfo::usable): Vulkan 1.3, a compute queue, 64-bit integers
// and floats in shaders, 64-bit atomics on buffers (depth maps as atomicMin of depth and
// triangle), buffer device addresses with the scalar block layout (kernels take their buffers
// as addresses in push constants, with the byte layouts of the *_shared.h headers), and
// timestamps on the compute queue. Mesa's lavapipe (the CPU driver CI runs) and NVIDIA's
// driver have all of them. Kernels never assume a subgroup size (lavapipe's is 8, NVIDIA's 32).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::gpu {

// One Vulkan physical device, as `penumbra devices` lists it.
struct DeviceInfo {
  int index = 0;                // what gpu:N names
  std::string name;             // "NVIDIA H100 80GB HBM3", "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string type;             // discrete, integrated, virtual, cpu or other
  std::string driver;           // the driver's name and version ("llvmpipe, Mesa 22.3.6")
  std::string api_version;      // "1.3.230"
  uint64_t memory_bytes = 0;    // the largest device-local memory heap
  uint32_t subgroup_size = 0;
  bool usable = false;          // has everything penumbra needs (see above)
  std::string unusable_reason;  // what it lacks, when !usable
};

// The Vulkan devices of this machine, in the loader's order. Throws Error when no Vulkan loader
// (libvulkan.so.1) can be opened or it has no driver.
std::vector<DeviceInfo> list_devices();

// Which device a render runs on: `--device cpu | gpu | gpu:N` (also Python's device=).
struct DeviceChoice {
  bool gpu = false;
  int index = -1;  // gpu:N; -1 = the first usable device (discrete, then integrated, then any)
  // Throws Error naming the text when it is none of the forms above.
  static DeviceChoice parse(std::string_view text);
  std::string to_string() const;  // "cpu", "gpu", "gpu:1"
  bool operator==(const DeviceChoice&) const = default;
};

class Buffer;
class Kernel;
struct DeviceState;

// An opened device: the logical device, its compute queue, the compiled kernels. One per
// physical device for the whole process (Device::get), so every render reuses the pipelines it
// compiled (lavapipe compiles a kernel in tens of milliseconds). Submissions are serialised
// (one queue); a Device may be used from several threads.
class Device {
 public:
  // The process's device for gpu:index (-1: the default choice), opened at the first call.
  // Throws Error when the index does not exist ("gpu:3: this machine has 1 Vulkan device"),
  // the device lacks a feature, or the loader is missing.
  static Device& get(int index = -1);
  static Device& get(const DeviceChoice& choice) { return get(choice.index); }

  const DeviceInfo& info() const;
  // Device-local bytes held by live Buffers, and the most a render may plan to hold: 90% of
  // the largest device-local heap (the driver and other programs need some).
  uint64_t allocated_bytes() const;
  uint64_t memory_capacity() const;
  // Nanoseconds per timestamp tick.
  double timestamp_period_ns() const;
  // The compute kernel compiled from the embedded SPIR-V module `name` (gpu/shaders.h); built
  // at its first use and kept. Throws Error naming it when no such module exists.
  const Kernel& kernel(std::string_view name);

  DeviceState& state() { return *state_; }
  ~Device();

 private:
  explicit Device(int index);
  std::unique_ptr<DeviceState> state_;
};

// Validation (the Khronos layers, when PENUMBRA_GPU_VALIDATION=1 at the time the first device
// opens): every message the layers send is printed to stderr and counted here. The tests run
// with validation on and fail on any message; so does the command line (app/main.cpp).
uint64_t validation_message_count();
bool validation_enabled();

namespace testing {
// Makes the next device-memory allocation or the next queue submission report a Vulkan error,
// as a driver out of memory or a lost device would: for the tests of the one-line errors. A
// process started with PENUMBRA_GPU_TEST_FAIL=allocation (or submission) has it armed from the
// start (the command line's tests).
enum class Failure { None, Allocation, Submission };
void fail_next(Failure failure);
}  // namespace testing

}  // namespace penumbra::gpu
