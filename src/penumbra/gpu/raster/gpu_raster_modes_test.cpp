// The GPU rasterizer's layered depth maps and fragment lists against the CPU rasterizer's, the
// shared prefix sum and min/max pyramid against the CPU's, and their buffers grown when too small.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "penumbra/core/rng.h"
#include "penumbra/eval/run_setup.h"
#include "penumbra/gpu/gpu_test_util.h"
#include "penumbra/gpu/minmax_pyramid_gpu.h"
#include "penumbra/gpu/raster/gpu_rasterizer.h"
#include "penumbra/gpu/scan_gpu.h"
#include "penumbra/raster/raster_triangle.h"
#include "penumbra/raster/shadow_view.h"

namespace penumbra::gpu {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::GpuTest;

Scene scene_file(const std::string& name) {
  RunSetup setup = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/" + name);
  setup.apply("resolution", "32");
  return setup.load();
}

// A view from the light's centre fitted to the corners of the objects' boxes in front of it, at
// most 80 degrees wide, resolution texels along its longer side.
LightView scene_view(const Scene& scene, int resolution) {
  const AreaLight& light = scene.lights[0];
  std::vector<Vec3f> corners;
  for (const SceneObject& o : scene.objects) {
    const Bounds3f b = o.mesh.bounds();
    for (int c = 0; c < 8; ++c)
      if (dot(b.corner(c) - light.center, light.frame.n) > 0) corners.push_back(b.corner(c));
  }
  ShadowViewFit fit;
  fit.resolution = resolution;
  fit.max_fov = 80;
  return fit_shadow_view(light.center, light.frame.n, light.frame.t, corners, scene.bounds(), fit);
}

class GpuRasterModes : public GpuTest {
 protected:
  // The layered maps of both rasterizers: the same layers in every texel but a few at triangle
  // edges (the CPU's and the GPU's coverage agree to 99.9%, gpu_rasterizer_test.cpp).
  void expect_same_layers(const Scene& scene, const LightView& view, const LayerOptions& options,
                          GpuRasterizer* rasterizer = nullptr) {
    const LayeredDepthMap cpu = render_layered_depth_map(gather_raster_triangles(scene), view, options);
    GpuScene gs(device(), scene);
    GpuRasterizer own(device());
    GpuRasterizer& r = rasterizer ? *rasterizer : own;
    CommandList cl(device());
    GpuLayeredDepthMap map;
    r.layered_depth_map(cl, [&] { cl.submit(); }, "raster", gs, view, options, &map);
    const LayeredDepthMap gpu = map.download();
    ASSERT_EQ(gpu.counts.size(), cpu.counts.size());
    size_t texels = 0, same = 0, layers = 0;
    float z_min = kInfinity;
    for (int y = 0; y < cpu.height; ++y)
      for (int x = 0; x < cpu.width; ++x) {
        ++texels;
        const auto a = cpu.layers(x, y), b = gpu.layers(x, y);
        if (!a.empty()) z_min = std::min(z_min, a[0].z);
        layers += a.size();
        bool equal = a.size() == b.size();
        for (size_t l = 0; equal && l < a.size(); ++l)
          equal = a[l].triangle == b[l].triangle && std::abs(a[l].z - b[l].z) <= 1e-6f * a[l].z &&
                  std::abs(a[l].depth - b[l].depth) <= 1e-5f && std::abs(a[l].opacity - b[l].opacity) <= 1e-5f;
        same += equal;
      }
    EXPECT_GE(static_cast<double>(same), 0.999 * static_cast<double>(texels));
    EXPECT_GT(layers, texels / 4) << "too few layers to compare";
    EXPECT_NEAR(map.z_min(), z_min, 1e-6f * z_min);
  }

  void expect_same_lists(const Scene& scene, const LightView& view, GpuRasterizer* rasterizer = nullptr) {
    const FragmentLists cpu = render_fragment_lists(gather_raster_triangles(scene), view);
    GpuScene gs(device(), scene);
    GpuRasterizer own(device());
    GpuRasterizer& r = rasterizer ? *rasterizer : own;
    CommandList cl(device());
    GpuFragmentLists lists;
    r.fragment_lists(cl, [&] { cl.submit(); }, "raster", gs, view, {}, &lists);
    const FragmentLists gpu = lists.download();
    ASSERT_EQ(gpu.offsets.size(), cpu.offsets.size());
    size_t texels = 0, same = 0;
    for (int y = 0; y < cpu.height; ++y)
      for (int x = 0; x < cpu.width; ++x) {
        ++texels;
        const auto a = cpu.at(x, y), b = gpu.at(x, y);
        bool equal = a.size() == b.size();
        for (size_t k = 0; equal && k < a.size(); ++k)
          equal = a[k].triangle == b[k].triangle && std::abs(a[k].z - b[k].z) <= 1e-6f * a[k].z &&
                  std::abs(a[k].opacity - b[k].opacity) <= 1e-5f;
        same += equal;
      }
    EXPECT_GE(static_cast<double>(same), 0.999 * static_cast<double>(texels));
    EXPECT_GT(gpu.total(), texels / 4) << "too few fragments to compare";
    EXPECT_NEAR(static_cast<double>(gpu.total()), static_cast<double>(cpu.total()), 0.001 * cpu.total());
    EXPECT_EQ(lists.total(), r.stats().fragments);
  }
};

TEST_F(GpuRasterModes, LayeredMapsEqualTheCpus) {
  const Scene bunny = scene_file("bunny.json");
  LayerOptions options;
  options.layers = 4;
  expect_same_layers(bunny, scene_view(bunny, 96), options);
  // Alpha-masked leaves, two-sided: coincident sheets join within epsilon.
  const Scene foliage = scene_file("foliage.json");
  options.layers = 3;
  expect_same_layers(foliage, scene_view(foliage, 80), options);
  // Coincident sheets only: where fragments chain (each within epsilon of the next) the CPU's
  // result depends on the input order and the GPU's is the greedy grouping from the front.
  options.distinct_epsilon = 1e-4f;
  expect_same_layers(foliage, scene_view(foliage, 80), options);
}

TEST_F(GpuRasterModes, FragmentListsEqualTheCpus) {
  const Scene foliage = scene_file("foliage.json");
  expect_same_lists(foliage, scene_view(foliage, 64));
  const Scene furball = scene_file("furball.json");
  expect_same_lists(furball, scene_view(furball, 48));  // deep lists: the heap sort
}

TEST_F(GpuRasterModes, BuffersThatAreTooSmallGrowAndTheMapsAreRenderedAgain) {
  const Scene furball = scene_file("furball.json");
  const LightView view = scene_view(furball, 48);
  GpuRasterizer r(device());
  r.set_fragment_capacity_for_testing(16);
  expect_same_lists(furball, view, &r);
  EXPECT_EQ(r.attempts(), 2);  // the counting pass sized the second
  expect_same_lists(furball, view, &r);
  EXPECT_EQ(r.attempts(), 1);
  // The layered map's set-up triangles and work items.
  GpuRasterizer small(device());
  small.set_capacities_for_testing(8, 8);
  LayerOptions options;
  options.layers = 3;
  expect_same_layers(furball, view, options, &small);
  EXPECT_GE(small.attempts(), 2);
}

TEST_F(GpuRasterModes, PrefixSumsEqualTheCpus) {
  Rng rng(5);
  GpuScan scan;
  for (uint32_t n : {1u, 2u, 511u, 512u, 513u, 262144u, 300001u}) {
    std::vector<uint32_t> values(n);
    for (uint32_t& v : values) v = static_cast<uint32_t>(rng.next_float() * 40);
    Buffer in = make_buffer<uint32_t>(device(), values, "test values");
    Buffer out(device(), (uint64_t(n) + 1) * 4, "test sums");
    CommandList cl(device());
    scan.exclusive(cl, in.address(), out.address(), n);
    cl.submit();
    const std::vector<uint32_t> got = out.download_vector<uint32_t>(n + 1);
    uint32_t sum = 0;
    for (uint32_t i = 0; i <= n; ++i) {
      ASSERT_EQ(got[i], sum) << "n " << n << " i " << i;
      if (i < n) sum += values[i];
    }
  }
}

TEST_F(GpuRasterModes, MinMaxPyramidsEqualTheCpus) {
  Rng rng(9);
  for (auto [w, h] : {std::pair{1, 1}, std::pair{37, 23}, std::pair{64, 64}, std::pair{100, 3}}) {
    std::vector<DepthRange> texels(static_cast<size_t>(w) * h);
    for (DepthRange& r : texels) {
      if (rng.next_float() < 0.3f) continue;  // empty
      const float a = rng.next_float(), b = rng.next_float();
      r = {std::min(a, b), std::max(a, b)};
    }
    const MinMaxPyramid cpu(w, h, texels);
    GpuMinMaxPyramid gpu;
    gpu.resize(device(), w, h, "a test pyramid");
    gpu.buffer().upload(texels.data(), texels.size() * sizeof(DepthRange));
    CommandList cl(device());
    gpu.build(cl);
    cl.submit();
    const std::vector<DepthRange> nodes = gpu.download_nodes();
    size_t k = 0;
    for (int l = 0; l < cpu.levels(); ++l)
      for (const DepthRange& r : cpu.level(l)) {
        ASSERT_EQ(nodes[k].lo, r.lo) << w << "x" << h << " level " << l;
        ASSERT_EQ(nodes[k].hi, r.hi) << w << "x" << h << " level " << l;
        ++k;
      }
    EXPECT_EQ(k, nodes.size());
  }
}

TEST(GpuRasterModesMemory, BytesCountEveryBuffer) {
  EXPECT_EQ(GpuLayeredDepthMap::bytes(10, 4, 5), 40u * (8 + 4 + 4 + 5 * 16) + sizeof(shader::RasterView));
  EXPECT_GT(GpuFragmentLists::bytes(64, 64, 10000), GpuFragmentLists::bytes(64, 64, 100));
  EXPECT_EQ(GpuScan::scratch_bytes(100), 0u);  // one block
  EXPECT_EQ(GpuScan::scratch_bytes(1000), 3u * 4u);  // two blocks: their totals and one more
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::gpu
