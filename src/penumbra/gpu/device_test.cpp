#include "penumbra/gpu/device.h"

#include <gtest/gtest.h>

#include <numeric>

#include "penumbra/core/error.h"
#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/commands.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/gpu/shaders.h"
#include "penumbra/gpu/vulkan_state.h"

namespace penumbra::gpu {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::GpuTest;

TEST(DeviceChoice, ParsesTheThreeForms) {
  EXPECT_FALSE(DeviceChoice::parse("cpu").gpu);
  EXPECT_TRUE(DeviceChoice::parse("gpu").gpu);
  EXPECT_EQ(DeviceChoice::parse("gpu").index, -1);
  EXPECT_EQ(DeviceChoice::parse("gpu:2").index, 2);
  EXPECT_EQ(DeviceChoice::parse("gpu:2").to_string(), "gpu:2");
  for (const char* bad : {"", "GPU", "gpu:", "gpu:-1", "gpu:x", "cuda", "gpu:99999999"})
    EXPECT_THROW(DeviceChoice::parse(bad), Error) << bad;
  try {
    DeviceChoice::parse("tpu");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--device tpu"), std::string::npos) << e.what();
  }
}

TEST(SpirvModules, EveryKernelIsEmbeddedWithItsName) {
  ASSERT_FALSE(spirv_modules().empty());
  for (const SpirvModule& m : spirv_modules()) {
    ASSERT_GE(m.words.size(), 5u) << m.name;
    EXPECT_EQ(m.words[0], 0x07230203u) << m.name << ": not SPIR-V";
  }
  EXPECT_NE(find_spirv("test_rng"), nullptr);
  EXPECT_EQ(find_spirv("no_such_kernel"), nullptr);
}

TEST_F(GpuTest, ListsTheDeviceItOpened) {
  const std::vector<DeviceInfo> all = list_devices();
  ASSERT_FALSE(all.empty());
  const DeviceInfo& d = device().info();
  ASSERT_LT(d.index, static_cast<int>(all.size()));
  EXPECT_EQ(all[d.index].name, d.name);
  EXPECT_TRUE(d.usable);
  EXPECT_GT(d.subgroup_size, 0u);
  EXPECT_GT(d.memory_bytes, 0u);
  EXPECT_FALSE(d.driver.empty());
}

TEST_F(GpuTest, ADeviceIndexThatDoesNotExistIsAOneLineError) {
  const size_t n = list_devices().size();
  try {
    Device::get(static_cast<int>(n) + 3);
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(fmt::format("gpu:{}", n + 3)), std::string::npos) << m;
    EXPECT_NE(m.find("penumbra devices"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

TEST_F(GpuTest, BuffersRoundTripAndCountTheirBytes) {
  const uint64_t before = device().allocated_bytes();
  {
    std::vector<uint32_t> v(1000);
    std::iota(v.begin(), v.end(), 7u);
    Buffer b = make_buffer<uint32_t>(device(), v, "a test buffer");
    EXPECT_GE(device().allocated_bytes(), before + 4000);
    EXPECT_NE(b.address(), 0u);
    EXPECT_EQ(b.download_vector<uint32_t>(1000), v);
    CommandList cl(device());
    cl.fill(b, 0xdeadbeefu, 400, 40);
    cl.submit();
    const std::vector<uint32_t> w = b.download_vector<uint32_t>(1000);
    for (size_t i = 0; i < 1000; ++i) EXPECT_EQ(w[i], i >= 100 && i < 110 ? 0xdeadbeefu : v[i]) << i;
  }
  EXPECT_EQ(device().allocated_bytes(), before);
}

// CommandList::dispatch folds a 1D grid of more than 65535 groups into rows of 65535 groups;
// pn_thread_index() (gpu/kernel_common.glsl) must number the threads of every row on from the
// last: each index of the dispatch exactly once.
TEST_F(GpuTest, AFoldedGridNumbersEveryThreadOnce) {
  const uint32_t n = 65535u * 64u + 1000u * 64u + 17u;  // a second row of 1001 groups, the last short
  Buffer counts(device(), uint64_t{n} * 4, "thread counts");
  struct Push {
    uint64_t counts;
    uint32_t n;
  } push{counts.address(), n};
  CommandList cl(device());
  cl.fill(counts, 0);
  cl.dispatch("test_thread_index", n, push);
  cl.submit();
  const std::vector<uint32_t> got = counts.download_vector<uint32_t>(n);
  size_t wrong = 0, first_wrong = n;
  for (size_t i = 0; i < n; ++i)
    if (got[i] != 1u && wrong++ == 0) first_wrong = i;
  EXPECT_EQ(wrong, 0u) << "first at index " << first_wrong << ": counted " << got[first_wrong] << " times";
}

// The memory types a device's buffers use, from memory properties written as drivers report them.
TEST(GpuMemoryTypes, DownloadsGoThroughACachedTypeAndKernelsBuffersStayDeviceLocal) {
  constexpr VkMemoryPropertyFlags kLocal = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
  constexpr VkMemoryPropertyFlags kHost = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  constexpr VkMemoryPropertyFlags kCached = VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
  const uint64_t gib = uint64_t{1} << 30;
  auto props = [](std::vector<uint64_t> heaps, std::vector<std::pair<VkMemoryPropertyFlags, uint32_t>> types) {
    VkPhysicalDeviceMemoryProperties m{};
    m.memoryHeapCount = static_cast<uint32_t>(heaps.size());
    for (size_t h = 0; h < heaps.size(); ++h) m.memoryHeaps[h].size = heaps[h];
    m.memoryTypeCount = static_cast<uint32_t>(types.size());
    for (size_t t = 0; t < types.size(); ++t) m.memoryTypes[t] = {types[t].first, types[t].second};
    return m;
  };
  // A discrete NVIDIA card: device memory, host memory write-combined and cached, and a
  // 256 MiB window of device memory the host can map.
  const MemoryTypes nv = choose_memory_types(
      props({80 * gib, 128 * gib, gib / 4},
            {{0, 1}, {kLocal, 0}, {kHost, 1}, {kHost | kCached, 1}, {kLocal | kHost, 2}}),
      80 * gib, false);
  EXPECT_EQ(nv.device_local, 1);
  EXPECT_FALSE(nv.device_local_host_visible);
  EXPECT_EQ(nv.staging, 2);   // uploads: write-combined
  EXPECT_EQ(nv.readback, 3);  // downloads: cached
  // No cached type: downloads share the staging type.
  const MemoryTypes plain = choose_memory_types(props({8 * gib, 16 * gib}, {{kLocal, 0}, {kHost, 1}}), 8 * gib, false);
  EXPECT_EQ(plain.device_local, 0);
  EXPECT_EQ(plain.staging, 1);
  EXPECT_EQ(plain.readback, 1);
  // Unified memory (lavapipe, an integrated GPU): kernels' buffers in the mappable type.
  const MemoryTypes cpu = choose_memory_types(props({2 * gib}, {{kLocal, 0}, {kLocal | kHost | kCached, 0}}), 2 * gib, true);
  EXPECT_EQ(cpu.device_local, 1);
  EXPECT_TRUE(cpu.device_local_host_visible);
  EXPECT_EQ(cpu.staging, 1);
  EXPECT_EQ(cpu.readback, 1);
  // No device-local type in the device's heap: none chosen (the device is refused).
  EXPECT_EQ(choose_memory_types(props({gib}, {{kHost, 0}}), 2 * gib, false).device_local, -1);
}

TEST_F(GpuTest, AFailedAllocationOrSubmissionIsAOneLineErrorNamingTheCall) {
  testing::fail_next(testing::Failure::Allocation);
  try {
    Buffer b(device(), 1 << 20, "the test's buffer");
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("vkAllocateMemory"), std::string::npos) << m;
    EXPECT_NE(m.find("the test's buffer"), std::string::npos) << m;
    EXPECT_NE(m.find("VK_ERROR_OUT_OF_DEVICE_MEMORY"), std::string::npos) << m;
  }
  Buffer b(device(), 64, "a buffer");
  CommandList cl(device());
  cl.fill(b, 1);
  testing::fail_next(testing::Failure::Submission);
  try {
    cl.submit();
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("vkQueueSubmit"), std::string::npos) << e.what();
  }
  // The device is still usable after either.
  cl.fill(b, 5);
  cl.submit();
  EXPECT_EQ(b.download_vector<uint32_t>(1)[0], 5u);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::gpu
