// For GPU tests: the device they run on, and a check that the Vulkan validation layers said
// nothing. In CI (PENUMBRA_REQUIRE_GPU=1, scripts/test.sh) a machine without a Vulkan device
// fails these tests instead of skipping them; elsewhere they skip with the reason.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/gpu/device.h"

namespace penumbra::gpu::testing {

// The device GPU tests use (the default choice), or null with `why` set.
inline Device* test_device(std::string* why) {
  try {
    return &Device::get(-1);
  } catch (const Error& e) {
    *why = e.what();
    return nullptr;
  }
}

inline bool gpu_required() {
  const char* v = std::getenv("PENUMBRA_REQUIRE_GPU");
  return v && *v && std::string(v) != "0";
}

// A fixture for GPU tests: device() is the device; after the test, no validation message.
class GpuTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    device_ = test_device(&why);
    if (!device_) {
      if (gpu_required()) FAIL() << "no Vulkan device, and PENUMBRA_REQUIRE_GPU is set: " << why;
      GTEST_SKIP() << "no Vulkan device: " << why;
    }
    messages_ = validation_message_count();
  }
  void TearDown() override {
    if (device_) EXPECT_EQ(validation_message_count(), messages_) << "the Vulkan validation layers reported problems";
  }
  Device& device() { return *device_; }

 private:
  Device* device_ = nullptr;
  uint64_t messages_ = 0;
};

}  // namespace penumbra::gpu::testing
