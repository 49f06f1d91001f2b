#include "penumbra/gpu/device.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>

#include "penumbra/core/error.h"
#include "penumbra/gpu/shaders.h"
#include "penumbra/gpu/vulkan_state.h"

namespace penumbra::gpu {

const char* result_name(VkResult r) {
  switch (r) {
    case VK_SUCCESS: return "VK_SUCCESS";
    case VK_NOT_READY: return "VK_NOT_READY";
    case VK_TIMEOUT: return "VK_TIMEOUT";
    case VK_INCOMPLETE: return "VK_INCOMPLETE";
    case VK_ERROR_OUT_OF_HOST_MEMORY: return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED: return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST: return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_MEMORY_MAP_FAILED: return "VK_ERROR_MEMORY_MAP_FAILED";
    case VK_ERROR_LAYER_NOT_PRESENT: return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT: return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_FEATURE_NOT_PRESENT: return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER: return "VK_ERROR_INCOMPATIBLE_DRIVER";
    case VK_ERROR_TOO_MANY_OBJECTS: return "VK_ERROR_TOO_MANY_OBJECTS";
    case VK_ERROR_UNKNOWN: return "VK_ERROR_UNKNOWN";
    default: return "VkResult error";
  }
}

void check(VkResult result, const char* call, const std::string& device_name, const std::string& context) {
  if (result == VK_SUCCESS) return;
  throw Error("GPU {}: {} failed ({}){}", device_name.empty() ? "(no device)" : device_name, call,
              result_name(result), context);
}

namespace {

std::atomic<uint64_t> g_validation_messages{0};
std::atomic<int> g_fail_next{0};

VKAPI_ATTR VkBool32 VKAPI_CALL debug_callback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                              VkDebugUtilsMessageTypeFlagsEXT,
                                              const VkDebugUtilsMessengerCallbackDataEXT* data, void*) {
  // Information and verbose messages are the loader's chatter; warnings and errors are findings.
  if (severity < VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) return VK_FALSE;
  ++g_validation_messages;
  std::fprintf(stderr, "penumbra: Vulkan validation: %s\n", data && data->pMessage ? data->pMessage : "(no text)");
  return VK_FALSE;
}

// The process's Vulkan instance: the loader opened (volk), validation layers when asked for.
struct Instance {
  VkInstance instance = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
  bool validation = false;
  std::string error;  // why there is no instance
};

Instance& shared_instance() {
  static Instance inst = [] {
    Instance i;
    if (volkInitialize() != VK_SUCCESS) {
      i.error = "no Vulkan loader: libvulkan.so.1 cannot be opened (Debian: apt install libvulkan1 "
                "mesa-vulkan-drivers; a bundle carries its own in lib/)";
      return i;
    }
    if (volkGetInstanceVersion() < VK_API_VERSION_1_3) {
      i.error = "the Vulkan loader is older than Vulkan 1.3";
      return i;
    }
    const char* v = std::getenv("PENUMBRA_GPU_VALIDATION");
    i.validation = v && std::strcmp(v, "0") != 0 && *v;
    std::vector<const char*> layers, extensions;
    if (i.validation) {
      uint32_t n = 0;
      vkEnumerateInstanceLayerProperties(&n, nullptr);
      std::vector<VkLayerProperties> props(n);
      vkEnumerateInstanceLayerProperties(&n, props.data());
      const bool found = std::any_of(props.begin(), props.end(), [](const VkLayerProperties& p) {
        return std::strcmp(p.layerName, "VK_LAYER_KHRONOS_validation") == 0;
      });
      if (!found) {
        i.error = "PENUMBRA_GPU_VALIDATION is set but the Khronos validation layer is not installed "
                  "(Debian: apt install vulkan-validationlayers)";
        return i;
      }
      layers.push_back("VK_LAYER_KHRONOS_validation");
      extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    }
    VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.pApplicationName = "penumbra";
    app.pEngineName = "penumbra";
    app.apiVersion = VK_API_VERSION_1_3;
    VkInstanceCreateInfo ci{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    ci.pApplicationInfo = &app;
    ci.enabledLayerCount = static_cast<uint32_t>(layers.size());
    ci.ppEnabledLayerNames = layers.data();
    ci.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
    ci.ppEnabledExtensionNames = extensions.data();
    VkDebugUtilsMessengerCreateInfoEXT mi{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
    mi.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    mi.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                     VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    mi.pfnUserCallback = debug_callback;
    if (i.validation) ci.pNext = &mi;  // also reports instance creation itself
    const VkResult r = vkCreateInstance(&ci, nullptr, &i.instance);
    if (r != VK_SUCCESS) {
      i.error = fmt::format("vkCreateInstance failed ({}): no Vulkan 1.3 driver", result_name(r));
      i.instance = VK_NULL_HANDLE;
      return i;
    }
    volkLoadInstanceOnly(i.instance);
    if (i.validation) vkCreateDebugUtilsMessengerEXT(i.instance, &mi, nullptr, &i.messenger);
    // Never destroyed: the instance lives as long as the process (drivers' own static state is
    // torn down in an order we do not control at exit).
    return i;
  }();
  return inst;
}

VkInstance instance_or_throw() {
  Instance& i = shared_instance();
  if (i.instance == VK_NULL_HANDLE) throw Error("GPU: {}", i.error);
  return i.instance;
}

std::vector<VkPhysicalDevice> physical_devices(VkInstance instance) {
  uint32_t n = 0;
  check(vkEnumeratePhysicalDevices(instance, &n, nullptr), "vkEnumeratePhysicalDevices", "");
  std::vector<VkPhysicalDevice> devices(n);
  check(vkEnumeratePhysicalDevices(instance, &n, devices.data()), "vkEnumeratePhysicalDevices", "");
  devices.resize(n);
  return devices;
}

const char* type_name(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
  }
}

// The feature chain penumbra enables (and checks for).
struct Features {
  VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  Features() {
    f2.pNext = &f12;
    f12.pNext = &f13;
  }
  // What penumbra needs that the queried chain lacks ("" when nothing).
  std::string missing() const {
    std::string m;
    auto need = [&](VkBool32 b, const char* name) {
      if (!b) m += m.empty() ? name : std::string(", ") + name;
    };
    need(f2.features.shaderInt64, "shaderInt64");
    need(f2.features.shaderFloat64, "shaderFloat64");
    need(f12.bufferDeviceAddress, "bufferDeviceAddress");
    need(f12.scalarBlockLayout, "scalarBlockLayout");
    need(f12.shaderBufferInt64Atomics, "shaderBufferInt64Atomics");
    need(f12.storageBuffer8BitAccess, "storageBuffer8BitAccess");
    need(f12.shaderInt8, "shaderInt8");
    need(f13.maintenance4, "maintenance4");
    need(f13.synchronization2, "synchronization2");
    return m;
  }
  // The chain to enable: exactly the features above.
  static Features wanted() {
    Features w;
    w.f2.features.shaderInt64 = VK_TRUE;
    w.f2.features.shaderFloat64 = VK_TRUE;
    w.f12.bufferDeviceAddress = VK_TRUE;
    w.f12.scalarBlockLayout = VK_TRUE;
    w.f12.shaderBufferInt64Atomics = VK_TRUE;
    w.f12.storageBuffer8BitAccess = VK_TRUE;
    w.f12.shaderInt8 = VK_TRUE;
    w.f13.maintenance4 = VK_TRUE;
    w.f13.synchronization2 = VK_TRUE;
    return w;
  }
};

int compute_queue_family(VkPhysicalDevice pd, bool* timestamps) {
  uint32_t n = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, nullptr);
  std::vector<VkQueueFamilyProperties> q(n);
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, q.data());
  // A compute-only family first (the asynchronous compute queue of a discrete GPU), else any
  // with compute.
  int best = -1;
  for (uint32_t i = 0; i < n; ++i) {
    if (!(q[i].queueFlags & VK_QUEUE_COMPUTE_BIT) || q[i].timestampValidBits == 0) continue;
    if (best < 0 || !(q[i].queueFlags & VK_QUEUE_GRAPHICS_BIT)) best = static_cast<int>(i);
  }
  *timestamps = best >= 0;
  if (best < 0)
    for (uint32_t i = 0; i < n; ++i)
      if (q[i].queueFlags & VK_QUEUE_COMPUTE_BIT) return static_cast<int>(i);
  return best;
}

DeviceInfo describe(VkPhysicalDevice pd, int index) {
  DeviceInfo info;
  info.index = index;
  VkPhysicalDeviceSubgroupProperties sub{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
  VkPhysicalDeviceDriverProperties drv{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
  sub.pNext = &drv;
  VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  p2.pNext = &sub;
  vkGetPhysicalDeviceProperties2(pd, &p2);
  const VkPhysicalDeviceProperties& p = p2.properties;
  info.name = p.deviceName;
  info.type = type_name(p.deviceType);
  info.driver = drv.driverName;
  if (drv.driverInfo[0]) info.driver += std::string(", ") + drv.driverInfo;
  info.api_version = fmt::format("{}.{}.{}", VK_API_VERSION_MAJOR(p.apiVersion), VK_API_VERSION_MINOR(p.apiVersion),
                                 VK_API_VERSION_PATCH(p.apiVersion));
  info.subgroup_size = sub.subgroupSize;
  VkPhysicalDeviceMemoryProperties mem;
  vkGetPhysicalDeviceMemoryProperties(pd, &mem);
  for (uint32_t h = 0; h < mem.memoryHeapCount; ++h)
    if (mem.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
      info.memory_bytes = std::max<uint64_t>(info.memory_bytes, mem.memoryHeaps[h].size);
  std::string why;
  if (p.apiVersion < VK_API_VERSION_1_3) why = "Vulkan " + info.api_version + " (penumbra needs 1.3)";
  bool timestamps = false;
  if (why.empty() && compute_queue_family(pd, &timestamps) < 0) why = "no compute queue";
  if (why.empty() && !timestamps) why = "no timestamps on its compute queues";
  if (why.empty()) {
    Features f;
    vkGetPhysicalDeviceFeatures2(pd, &f.f2);
    const std::string m = f.missing();
    if (!m.empty()) why = "lacks " + m;
  }
  info.usable = why.empty();
  info.unusable_reason = why;
  return info;
}

int default_device(const std::vector<DeviceInfo>& infos) {
  for (const char* type : {"discrete", "integrated", "virtual", "cpu", "other"})
    for (const DeviceInfo& d : infos)
      if (d.usable && d.type == type) return d.index;
  return -1;
}

}  // namespace

std::vector<DeviceInfo> list_devices() {
  const VkInstance instance = instance_or_throw();
  std::vector<DeviceInfo> out;
  int index = 0;
  for (VkPhysicalDevice pd : physical_devices(instance)) out.push_back(describe(pd, index++));
  return out;
}

DeviceChoice DeviceChoice::parse(std::string_view text) {
  DeviceChoice c;
  if (text == "cpu") return c;
  c.gpu = true;
  if (text == "gpu") return c;
  if (text.substr(0, 4) == "gpu:" && text.size() > 4 && text.size() < 8 &&
      std::all_of(text.begin() + 4, text.end(), [](char ch) { return ch >= '0' && ch <= '9'; })) {
    c.index = std::stoi(std::string(text.substr(4)));
    return c;
  }
  throw Error("--device {}: expected cpu, gpu or gpu:N (N from `penumbra devices`)", std::string(text));
}

std::string DeviceChoice::to_string() const {
  if (!gpu) return "cpu";
  return index < 0 ? "gpu" : fmt::format("gpu:{}", index);
}

uint64_t validation_message_count() { return g_validation_messages.load(); }
bool validation_enabled() { return shared_instance().validation; }

namespace testing {
void fail_next(Failure failure) { g_fail_next = static_cast<int>(failure); }
}  // namespace testing

VkDeviceMemory DeviceState::allocate(uint64_t bytes, uint32_t type, const std::string& what, bool device_address) {
  const std::string context = fmt::format(" allocating {:.1f} MiB for {}", static_cast<double>(bytes) / (1 << 20), what);
  int want = static_cast<int>(testing::Failure::Allocation);
  if (g_fail_next.compare_exchange_strong(want, 0))
    check(VK_ERROR_OUT_OF_DEVICE_MEMORY, "vkAllocateMemory", info.name, context);
  VkMemoryAllocateFlagsInfo flags{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO};
  flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
  VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  ai.pNext = device_address ? &flags : nullptr;
  ai.allocationSize = bytes;
  ai.memoryTypeIndex = type;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  check(vkAllocateMemory(device, &ai, nullptr, &memory), "vkAllocateMemory", info.name, context);
  return memory;
}

VkCommandBuffer DeviceState::begin_one_time() {
  std::lock_guard lock(mutex);
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = command_pool;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  VkCommandBuffer cb = VK_NULL_HANDLE;
  check(vkAllocateCommandBuffers(device, &ai, &cb), "vkAllocateCommandBuffers", info.name);
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(cb, &bi), "vkBeginCommandBuffer", info.name);
  return cb;
}

void DeviceState::free_command_buffer(VkCommandBuffer cb) {
  std::lock_guard lock(mutex);
  vkFreeCommandBuffers(device, command_pool, 1, &cb);
}

void DeviceState::submit_and_wait(VkCommandBuffer cb) {
  check(vkEndCommandBuffer(cb), "vkEndCommandBuffer", info.name);
  int want = static_cast<int>(testing::Failure::Submission);
  if (g_fail_next.compare_exchange_strong(want, 0)) check(VK_ERROR_DEVICE_LOST, "vkQueueSubmit", info.name);
  VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  VkFence fence = VK_NULL_HANDLE;
  check(vkCreateFence(device, &fi, nullptr, &fence), "vkCreateFence", info.name);
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cb;
  VkResult r;
  {
    std::lock_guard lock(mutex);
    r = vkQueueSubmit(queue, 1, &si, fence);
  }
  if (r == VK_SUCCESS) r = vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX);
  vkDestroyFence(device, fence, nullptr);
  check(r, "vkQueueSubmit", info.name);
}

Device::Device(int index) : state_(std::make_unique<DeviceState>()) {
  const VkInstance instance = instance_or_throw();
  const std::vector<VkPhysicalDevice> pds = physical_devices(instance);
  std::vector<DeviceInfo> infos;
  for (size_t i = 0; i < pds.size(); ++i) infos.push_back(describe(pds[i], static_cast<int>(i)));
  if (pds.empty()) throw Error("--device gpu: this machine has no Vulkan device");
  if (index < 0) {
    index = default_device(infos);
    if (index < 0)
      throw Error("--device gpu: no usable Vulkan device (gpu:0, {}: {})", infos[0].name, infos[0].unusable_reason);
  }
  if (index >= static_cast<int>(pds.size()))
    throw Error("--device gpu:{}: this machine has {} Vulkan device{} (gpu:0{}; `penumbra devices` lists them)", index,
                pds.size(), pds.size() == 1 ? "" : "s", pds.size() == 1 ? "" : fmt::format(" to gpu:{}", pds.size() - 1));
  DeviceState& s = *state_;
  s.info = infos[index];
  if (!s.info.usable) throw Error("--device gpu:{}: {} {}", index, s.info.name, s.info.unusable_reason);
  s.instance = instance;
  s.physical = pds[index];
  bool timestamps = false;
  s.queue_family = static_cast<uint32_t>(compute_queue_family(s.physical, &timestamps));
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qi{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qi.queueFamilyIndex = s.queue_family;
  qi.queueCount = 1;
  qi.pQueuePriorities = &priority;
  Features wanted = Features::wanted();
  VkDeviceCreateInfo di{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  di.pNext = &wanted.f2;
  di.queueCreateInfoCount = 1;
  di.pQueueCreateInfos = &qi;
  check(vkCreateDevice(s.physical, &di, nullptr, &s.device), "vkCreateDevice", s.info.name);
  volkLoadDevice(s.device);
  vkGetDeviceQueue(s.device, s.queue_family, 0, &s.queue);

  VkCommandPoolCreateInfo pi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pi.queueFamilyIndex = s.queue_family;
  check(vkCreateCommandPool(s.device, &pi, nullptr, &s.command_pool), "vkCreateCommandPool", s.info.name);

  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, Kernel::kMaxPushBytes};
  VkPipelineLayoutCreateInfo li{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  li.pushConstantRangeCount = 1;
  li.pPushConstantRanges = &range;
  check(vkCreatePipelineLayout(s.device, &li, nullptr, &s.pipeline_layout), "vkCreatePipelineLayout", s.info.name);

  // Memory types (choose_memory_types): kernels' buffers device-local, uploads through a
  // write-combined staging type, downloads through a cached one where the device has it.
  VkPhysicalDeviceMemoryProperties mem;
  vkGetPhysicalDeviceMemoryProperties(s.physical, &mem);
  s.memory = choose_memory_types(mem, s.info.memory_bytes, s.info.type == "cpu" || s.info.type == "integrated");
  if (s.memory.device_local < 0 || s.memory.staging < 0)
    throw Error("--device gpu:{}: {} has no usable memory types", index, s.info.name);
  s.heap_bytes = s.info.memory_bytes;
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(s.physical, &props);
  s.timestamp_period_ns = props.limits.timestampPeriod;
}

MemoryTypes choose_memory_types(const VkPhysicalDeviceMemoryProperties& mem, uint64_t device_heap_bytes, bool unified) {
  MemoryTypes out;
  auto has = [](VkMemoryPropertyFlags f, VkMemoryPropertyFlags want) { return (f & want) == want; };
  const VkMemoryPropertyFlags host = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  for (uint32_t t = 0; t < mem.memoryTypeCount; ++t) {
    const VkMemoryPropertyFlags f = mem.memoryTypes[t].propertyFlags;
    const uint64_t heap = mem.memoryHeaps[mem.memoryTypes[t].heapIndex].size;
    if (has(f, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT) && heap == device_heap_bytes) {
      if (out.device_local < 0) out.device_local = static_cast<int>(t);
      if (has(f, host) && unified && !has(mem.memoryTypes[out.device_local].propertyFlags, host))
        out.device_local = static_cast<int>(t);
    }
    if (has(f, host) && out.staging < 0) out.staging = static_cast<int>(t);
    if (has(f, host | VK_MEMORY_PROPERTY_HOST_CACHED_BIT) && out.readback < 0) out.readback = static_cast<int>(t);
  }
  if (out.readback < 0) out.readback = out.staging;
  out.device_local_host_visible =
      out.device_local >= 0 && unified && has(mem.memoryTypes[out.device_local].propertyFlags, host);
  return out;
}

Device::~Device() = default;  // never runs for the shared devices (see get)

Device& Device::get(int index) {
  // PENUMBRA_GPU_TEST_FAIL=allocation|submission: the process's first allocation or submission
  // fails (testing::fail_next), so the command line's tests see its one-line error.
  static const bool armed = [] {
    const char* f = std::getenv("PENUMBRA_GPU_TEST_FAIL");
    if (f && std::strcmp(f, "allocation") == 0) testing::fail_next(testing::Failure::Allocation);
    if (f && std::strcmp(f, "submission") == 0) testing::fail_next(testing::Failure::Submission);
    return true;
  }();
  (void)armed;
  static std::mutex mutex;
  // Opened once per index and never closed: pipelines stay compiled for the whole process,
  // and nothing is torn down during static destruction, when driver state may already be gone.
  // The table itself is never destroyed either, so the devices stay reachable to the end (a
  // destroyed table would leave them to LeakSanitizer's exit check as leaks).
  static auto* devices = new std::map<int, Device*>();
  std::lock_guard lock(mutex);
  auto it = devices->find(index);
  if (it != devices->end()) return *it->second;
  Device* d = new Device(index);
  (*devices)[index] = d;
  if (index < 0) (*devices)[d->info().index] = d;
  return *d;
}

const DeviceInfo& Device::info() const { return state_->info; }
uint64_t Device::allocated_bytes() const { return state_->allocated.load(); }
uint64_t Device::memory_capacity() const { return state_->heap_bytes / 10 * 9; }
double Device::timestamp_period_ns() const { return state_->timestamp_period_ns; }

const SpirvModule* find_spirv(std::string_view name) {
  for (const SpirvModule& m : spirv_modules())
    if (m.name == name) return &m;
  return nullptr;
}

namespace {
// The workgroup size of a compute module: OpExecutionMode LocalSize (literals) or
// OpExecutionModeId LocalSizeId (ids of constants, what glslc emits for Vulkan 1.3).
void local_size(std::span<const uint32_t> words, uint32_t out[3]) {
  std::map<uint32_t, uint32_t> constants;  // OpConstant result id -> value (32-bit ones)
  const uint32_t* ids = nullptr;
  for (size_t i = 5; i < words.size();) {
    const uint32_t count = words[i] >> 16, op = words[i] & 0xffffu;
    if (count == 0 || i + count > words.size()) break;
    if (op == 16 /*OpExecutionMode*/ && count >= 6 && words[i + 2] == 17 /*LocalSize*/) {
      out[0] = words[i + 3], out[1] = words[i + 4], out[2] = words[i + 5];
      return;
    }
    if (op == 331 /*OpExecutionModeId*/ && count >= 6 && words[i + 2] == 38 /*LocalSizeId*/) ids = &words[i + 3];
    if (op == 43 /*OpConstant*/ && count == 4) constants[words[i + 2]] = words[i + 3];
    i += count;
  }
  if (ids)
    for (int k = 0; k < 3; ++k) out[k] = constants.count(ids[k]) ? constants[ids[k]] : 1;
}
}  // namespace

const Kernel& Device::kernel(std::string_view name) {
  DeviceState& s = *state_;
  std::lock_guard lock(s.mutex);
  auto it = s.kernels.find(name);
  if (it != s.kernels.end()) return *it->second;
  const SpirvModule* module = find_spirv(name);
  if (!module) throw Error("GPU: no kernel named {} is built into this program", std::string(name));
  auto k = std::make_unique<Kernel>();
  k->name = std::string(name);
  local_size(module->words, k->local_size);
  VkShaderModuleCreateInfo mi{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  mi.codeSize = module->words.size_bytes();
  mi.pCode = module->words.data();
  VkShaderModule sm = VK_NULL_HANDLE;
  check(vkCreateShaderModule(s.device, &mi, nullptr, &sm), "vkCreateShaderModule", s.info.name, " for " + k->name);
  VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  ci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  ci.stage.module = sm;
  ci.stage.pName = "main";
  ci.layout = s.pipeline_layout;
  VkPipeline pipeline = VK_NULL_HANDLE;
  const VkResult r = vkCreateComputePipelines(s.device, VK_NULL_HANDLE, 1, &ci, nullptr, &pipeline);
  vkDestroyShaderModule(s.device, sm, nullptr);
  check(r, "vkCreateComputePipelines", s.info.name, " for " + k->name);
  k->pipeline = reinterpret_cast<uint64_t>(pipeline);
  return *s.kernels.emplace(k->name, std::move(k)).first->second;
}

}  // namespace penumbra::gpu
