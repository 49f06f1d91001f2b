// gpu/scan.h: the exclusive prefix sum on the device equals the CPU's, with the total after the
// values, for lengths below, at and above the kernel's 256 threads and far above (long runs per
// thread), zeros included.
#include "penumbra/gpu/scan.h"

#include <gtest/gtest.h>

#include <vector>

#include "penumbra/core/rng.h"
#include "penumbra/gpu/buffer.h"
#include "penumbra/gpu/gpu_test_util.h"

namespace penumbra::gpu {
namespace {

class GpuScan : public testing::GpuTest {};

TEST_F(GpuScan, ExclusiveScanEqualsTheCpusWithTheTotalAfter) {
  Rng rng(91);
  for (uint32_t n : {1u, 7u, 255u, 256u, 257u, 1000u, 65536u, 300001u}) {
    std::vector<uint32_t> values(n + 1, 0xdeadbeefu);
    for (uint32_t i = 0; i < n; ++i) values[i] = rng.next_float() < 0.3f ? 0u : static_cast<uint32_t>(rng.next_float() * 40);
    Buffer buf = make_buffer<uint32_t>(device(), values, "scan values");
    CommandList cl(device());
    exclusive_scan(cl, buf.address(), n);
    cl.submit();
    const std::vector<uint32_t> got = buf.download_vector<uint32_t>(n + 1);
    uint32_t sum = 0;
    for (uint32_t i = 0; i < n; ++i) {
      ASSERT_EQ(got[i], sum) << "n " << n << " index " << i;
      sum += values[i];
    }
    EXPECT_EQ(got[n], sum) << "n " << n;
  }
}

}  // namespace
}  // namespace penumbra::gpu
