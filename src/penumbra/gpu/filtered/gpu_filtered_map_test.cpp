// The GPU's prefiltered maps (gpu_filtered_map.h) against the CPU's (raster/filtered_map.h,
// occlusion_textures/prefilter.h): the same tables and chains bit for bit (the same additions in
// the same order), and the double exp and log the shared moment code runs on the GPU.
#include "penumbra/gpu/filtered/gpu_filtered_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "penumbra/core/rng.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/raster/filtered_map.h"
#include "penumbra/shadow/occlusion_textures/prefilter.h"

namespace penumbra::gpu {
namespace {
namespace PENUMBRA_UNITY_ID {

class GpuFilteredMap : public testing::GpuTest {};

std::vector<float> random_texels(int n, uint64_t seed) {
  std::vector<float> t(n);
  Rng rng(seed);
  for (float& v : t) v = rng.next_float() * 3 - 1;
  return t;
}

TEST_F(GpuFilteredMap, SummedAreaTableOfFloatsIsTheCpusBitForBit) {
  for (int C : {1, 2, 4}) {
    const int w = 37, h = 70;  // not powers of two; more rows than a group
    const std::vector<float> texels = random_texels(w * h * C, 7 + C);
    const std::vector<float> outside(C, 1.0f);
    SummedAreaTable cpu;
    cpu.build(ChannelImage{w, h, C, texels}, outside);
    Buffer source = make_buffer<float>(device(), texels, "texels");
    CommandList cl(device());
    GpuSummedAreaTable gpu;
    gpu.build_from_floats(device(), cl, [&] { cl.submit(); }, source.address(), w, h, C);
    cl.submit();
    ASSERT_EQ(GpuSummedAreaTable::bytes(w, h, C, GpuSummedAreaTable::Entries::Double), cpu.memory_bytes());
    ASSERT_GE(gpu.device_bytes(), cpu.memory_bytes());
    const size_t n = cpu.memory_bytes() / sizeof(double);
    const std::vector<double> table = gpu.buffer().download_vector<double>(n);
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(table[i], cpu.data()[i]) << C << " channels, entry " << i;
    const shader::SatTableLayout a = gpu.layout(), b = cpu.layout();
    EXPECT_EQ(std::tie(a.width, a.height, a.channels, a.x_stride, a.row_stride, a.channel_stride),
              std::tie(b.width, b.height, b.channels, b.x_stride, b.row_stride, b.channel_stride));
  }
}

TEST_F(GpuFilteredMap, SummedAreaTablesOfBitPlanesAreTheOcclusionTexturesTables) {
  const int w = 64, h = 48, S = 19;
  std::vector<uint32_t> masks(w * h);
  Rng rng(3);
  for (uint32_t& m : masks) m = static_cast<uint32_t>(rng.next_u64()) & ((1u << S) - 1);
  const occlusion::CoverageStack stack{w, h, S, masks};
  occlusion::SatFilter<uint32_t> counts;
  counts.build(stack);
  occlusion::SatFilter<double> doubles;
  doubles.build(stack);
  Buffer source = make_buffer<uint32_t>(device(), masks, "masks");
  CommandList cl(device());
  GpuSummedAreaTable gpu_counts, gpu_doubles;
  gpu_counts.build_from_bits(device(), cl, [&] { cl.submit(); }, source.address(), w, h, S,
                             GpuSummedAreaTable::Entries::Uint32);
  gpu_doubles.build_from_bits(device(), cl, [&] { cl.submit(); }, source.address(), w, h, S,
                              GpuSummedAreaTable::Entries::Double);
  cl.submit();
  const size_t n = static_cast<size_t>(w + 1) * (h + 1) * S;
  const std::vector<uint32_t> c = gpu_counts.buffer().download_vector<uint32_t>(n);
  const std::vector<double> d = gpu_doubles.buffer().download_vector<double>(n);
  const shader::SatTableLayout l = gpu_counts.layout();
  for (int k = 0; k < S; ++k)
    for (int y = 0; y <= h; ++y)
      for (int x = 0; x <= w; ++x) {
        const size_t i = k * l.channel_stride + y * l.row_stride + x;
        ASSERT_EQ(c[i], counts.entry(k, x, y)) << k << " " << x << " " << y;
        ASSERT_EQ(d[i], doubles.entry(k, x, y)) << k << " " << x << " " << y;
      }
}

TEST_F(GpuFilteredMap, MipChainIsTheCpusBitForBit) {
  const int w = 20, h = 13, C = 3;  // padded to 32 x 32
  const std::vector<float> texels = random_texels(w * h * C, 11);
  const std::vector<float> outside = {1.0f, 0.25f, -2.0f};
  MipChain cpu;
  cpu.build(ChannelImage{w, h, C, texels}, outside);
  Buffer source = make_buffer<float>(device(), texels, "texels");
  CommandList cl(device());
  GpuMipChain gpu;
  gpu.build(device(), cl, [&] { cl.submit(); }, source.address(), w, h, C, outside);
  cl.submit();
  EXPECT_EQ(gpu.view().levels, cpu.levels());
  ASSERT_EQ(GpuMipChain::bytes(w, h, C), cpu.memory_bytes());
  ASSERT_GE(gpu.device_bytes(), cpu.memory_bytes());
  const size_t n = cpu.memory_bytes() / sizeof(float);
  const std::vector<float> chain = gpu.buffer().download_vector<float>(n);
  for (size_t i = 0; i < n; ++i) ASSERT_EQ(chain[i], cpu.texels()[i]) << i;
}

TEST_F(GpuFilteredMap, TablesGrowForALargerMapAndRefuseBadChannelCounts) {
  CommandList cl(device());
  int submits = 0;
  const SubmitRecorded submit = [&] {
    ++submits;
    cl.submit();
  };
  std::vector<float> small = random_texels(4 * 4, 1), large = random_texels(40 * 30, 2);
  Buffer a = make_buffer<float>(device(), small, "small"), b = make_buffer<float>(device(), large, "large");
  GpuSummedAreaTable t;
  t.build_from_floats(device(), cl, submit, a.address(), 4, 4, 1);
  EXPECT_EQ(submits, 0);  // nothing to replace
  t.build_from_floats(device(), cl, submit, b.address(), 40, 30, 1);
  EXPECT_EQ(submits, 1);  // the smaller table's readers ran first
  cl.submit();
  SummedAreaTable cpu;
  cpu.build(ChannelImage{40, 30, 1, large}, std::vector<float>{0.0f});
  EXPECT_EQ(t.buffer().download_vector<double>(41 * 31).back(), cpu.data()[41 * 31 - 1]);
  EXPECT_THROW(t.build_from_floats(device(), cl, submit, b.address(), 40, 30, 5), Error);
  EXPECT_THROW(t.build_from_bits(device(), cl, submit, b.address(), 40, 30, 33, GpuSummedAreaTable::Entries::Uint32),
               Error);
}

TEST_F(GpuFilteredMap, DoubleExpAndLogAreWithinAnUlpOrTwoOfLibm) {
  std::vector<double> x;
  Rng rng(5);
  for (int i = 0; i < 5000; ++i) x.push_back((rng.next_float() * 2 - 1) * 90.0 + rng.next_float() * 1e-7);
  for (double v : {0.0, 1.0, -1.0, 42.0, -42.0, 84.0, 1e-300, 0.5}) x.push_back(v);
  Buffer in = make_buffer<double>(device(), x, "values");
  Buffer out_exp(device(), x.size() * 8, "exp"), out_log(device(), x.size() * 8, "log");
  struct Push {
    uint64_t in, out_exp, out_log;
    uint32_t count;
  } push{in.address(), out_exp.address(), out_log.address(), static_cast<uint32_t>(x.size())};
  CommandList cl(device());
  cl.dispatch("test_filtered_math", x.size(), push);
  cl.submit();
  const std::vector<double> e = out_exp.download_vector<double>(x.size()), l = out_log.download_vector<double>(x.size());
  for (size_t i = 0; i < x.size(); ++i) {
    const double want_exp = std::exp(x[i]), want_log = std::log(std::abs(x[i]) + 1e-300);
    ASSERT_LE(std::abs(e[i] - want_exp), 4e-16 * want_exp) << x[i];
    ASSERT_LE(std::abs(l[i] - want_log), 4e-16 * std::max(1.0, std::abs(want_log))) << x[i];
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::gpu
