// Light-space partitions (light_partitions.h): the plan follows the casters, the guard samples
// sit xie2007 eq. 1's margin beyond a partition, a partitioned map is closer to the exact hard
// shadow where one map cannot hold the casters, nothing is split where it can, and the GPU's
// partitions give the CPU's pictures.
#include "penumbra/shadow/partitions/light_partitions.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <cstdio>
#include <string>

#include "penumbra/eval/run_setup.h"
#include "penumbra/testing/gpu_method_runs.h"

namespace penumbra::partitions {
namespace {
namespace PENUMBRA_UNITY_ID {

AreaLight test_light() {
  AreaLight l;
  l.shape = LightShape::Rect;
  l.center = {0, 10, 0};
  l.frame = Frame::from_z({0, -1, 0});
  l.size = {2, 2};
  return l;
}

Bounds3f scene_box() {
  Bounds3f b;
  b.extend(Vec3f(-10, 0, -10));
  b.extend(Vec3f(10, 10, 10));
  return b;
}

// Receivers on a plane 10 below the light filling x/z, y/z in [-1, 1]: one in every cell.
ReceiverGrid full_grid(int grid) {
  ReceiverGrid r;
  r.grid = grid;
  r.range.add(-1, -1, 10);
  r.range.add(1, 1, 10);
  r.counts.assign(static_cast<size_t>(grid) * grid, 1);
  return r;
}

TEST(LightPartitions, SplitsOnlyWhereCastersOutnumberTheTexels) {
  const AreaLight light = test_light();
  const ShadowViewFrame frame = light_frame(light, scene_box());
  Settings s;
  s.max_side = 8;
  s.density = 1;
  s.map_texels = 100;
  s.receiver_density = 1e9f;  // the casters' rule alone
  const ReceiverGrid receivers = full_grid(grid_cells(s));
  // 1000 casters in the quadrant x/z, y/z in (0.5, 1) x (0.5, 1), 10 elsewhere.
  CasterCentroids casters;
  casters.z_min = 5;
  for (int i = 0; i < 1000; ++i) casters.xyz.push_back({0.51f + 0.48f * (i % 31) / 31.0f, 0.51f + 0.48f * (i / 31) / 33.0f, 5});
  for (int i = 0; i < 10; ++i) casters.xyz.push_back({-0.9f + 0.1f * i, -0.5f, 5});
  const Plan plan = make_plan(frame, receivers, casters, light, s);
  // Root (1010 > 100) splits; the dense quadrant (1000) splits again, and its quarters (~250)
  // once more (~62 each); the sparse quadrants stay whole: 3 + 4 x ... leaves, every cell in one.
  EXPECT_GT(plan.leaves, 4);
  std::set<int32_t> used(plan.leaf_of_cell.begin(), plan.leaf_of_cell.end());
  EXPECT_EQ(static_cast<int>(used.size()), plan.leaves);
  EXPECT_EQ(used.count(-1), 0u);
  // A leaf in the sparse corner (x/z, y/z near -1) covers a quarter of the grid.
  const int G = plan.grid;
  const int corner = plan.leaf_of_cell[0];
  int corner_cells = 0;
  for (int32_t l : plan.leaf_of_cell) corner_cells += l == corner;
  EXPECT_EQ(corner_cells, G * G / 4);

  EXPECT_TRUE(could_split(casters, s, 0));
  EXPECT_TRUE(may_split(frame, receivers.range, casters, s, 0));
  Settings sparse = s;
  sparse.density = 1010.0f / 100;  // exactly the casters: not more, no split
  EXPECT_FALSE(could_split(casters, sparse, 0));
  EXPECT_FALSE(may_split(frame, receivers.range, casters, sparse, 0));
  EXPECT_EQ(make_plan(frame, receivers, casters, light, sparse).leaves, 1);

  Settings one = s;
  one.density = 1e6;
  EXPECT_EQ(make_plan(frame, receivers, casters, light, one).leaves, 1);
  one = s;
  one.max_side = 1;
  EXPECT_EQ(make_plan(frame, receivers, casters, light, one).leaves, 1);
  // Empty cells (no receiver) belong to no partition.
  ReceiverGrid half = receivers;
  for (int y = 0; y < G; ++y)
    for (int x = 0; x < G / 2; ++x) half.counts[y * G + x] = 0;
  const Plan p = make_plan(frame, half, casters, light, s);
  EXPECT_EQ(p.leaf_of_cell[0], -1);
  EXPECT_GE(p.leaf_of_cell[G - 1], 0);
}

TEST(LightPartitions, SplitsWhereTheViewSamplesOutnumberTheTexels) {
  // A camera near one corner of light space: 500 view samples in each of that corner's four
  // cells, one in every other cell, and too few casters to split anything.
  const AreaLight light = test_light();
  const ShadowViewFrame frame = light_frame(light, scene_box());
  Settings s;
  s.max_side = 8;
  s.density = 1e9f;
  const int G = grid_cells(s);  // 64
  s.map_texels = G * G * 100;   // a cell gets 100 texels of the root's map, 400 of a quadrant's
  s.receiver_density = 1;
  ReceiverGrid receivers = full_grid(G);
  for (int c : {0, 1, G, G + 1}) receivers.counts[c] = 500;
  CasterCentroids casters;
  casters.z_min = 5;
  casters.xyz.push_back({0.0f, 0.0f, 5});
  // The root splits (500 > 100), the corner's quadrant again (500 > 400), its children not
  // (500 < 1600); the other quadrants hold one sample a cell: 3 + 4 partitions.
  const Plan plan = make_plan(frame, receivers, casters, light, s);
  EXPECT_EQ(plan.leaves, 7);
  int corner_cells = 0;
  for (int32_t l : plan.leaf_of_cell) corner_cells += l == plan.leaf_of_cell[0];
  EXPECT_EQ(corner_cells, G * G / 16);
  // Fewer samples in all than one root cell's texels: no frame of them could split.
  EXPECT_FALSE(could_split(casters, s, 100));
  EXPECT_TRUE(could_split(casters, s, 101));
  EXPECT_TRUE(may_split(frame, receivers.range, casters, s, 101));
  Settings sparse = s;
  sparse.receiver_density = 5;  // 500 texels a root cell: nothing splits
  EXPECT_EQ(make_plan(frame, receivers, casters, light, sparse).leaves, 1);
}

TEST(LightPartitions, GuardSamplesSitTheBlockerSearchMarginBeyondThePartition) {
  const AreaLight light = test_light();
  const ShadowViewFrame frame = light_frame(light, scene_box());
  Settings s;
  s.max_side = 2;
  s.density = 0;
  const ReceiverGrid receivers = full_grid(grid_cells(s));
  CasterCentroids casters;
  casters.z_min = 4;
  casters.xyz.push_back({0, 0, 4});
  const Plan plan = make_plan(frame, receivers, casters, light, s);
  ASSERT_EQ(plan.leaves, 4);
  // xie2007 eq. 1 in x/z units: r (1/z_min - 1/z_r), r = the rect's extent radius sqrt(2).
  const float margin = std::sqrt(2.0f) * (1.0f / 4 - 1.0f / 10);
  for (int l = 0; l < plan.leaves; ++l) {
    float lo = kInfinity, hi = -kInfinity;
    for (Vec3f g : plan.guards[l]) {
      float x, y, z;
      ASSERT_TRUE(shader::shadow_view_project(frame.axes, g, x, y, z));
      EXPECT_NEAR(z, 10.0f, 1e-4f);
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    // Each partition is half the root ([-1, 0] or [0, 1]) widened by the margin on both sides.
    EXPECT_NEAR(hi - lo, 1.0f + 2 * margin, 1e-3f) << l;
    EXPECT_EQ(plan.guard_count(l), 4);
  }
  // A method whose fit holds the segments toward the light itself (the multilayer maps) gets
  // guards only where a partition has nothing to fit to: no occupied cell wholly within 90% of
  // max_fov (here every cell is within 54 degrees of the axis; at a 10 degree max_fov none is).
  Settings own = s;
  own.guards = GuardSamples::OnlyToFit;
  const Plan fitted = make_plan(frame, receivers, casters, light, own);
  ASSERT_EQ(fitted.leaves, 4);
  for (int l = 0; l < fitted.leaves; ++l) EXPECT_EQ(fitted.guard_count(l), 0) << l;
  own.max_fov = 10;
  const Plan narrow = make_plan(frame, receivers, casters, light, own);
  for (int l = 0; l < narrow.leaves; ++l) EXPECT_EQ(narrow.guard_count(l), 4) << l;
}

RenderSettings cpu_settings(const std::string& method, std::vector<std::string> params) {
  return testing::device_settings(method, std::move(params), false);
}

// A dense wide scene: four generated trees (about 240 k triangles) under a far light.
Scene small_forest(int resolution) {
  RunSetup setup = RunSetup::from_file(std::string(PENUMBRA_SOURCE_DIR) + "/scenes/forest.json");
  setup.apply("resolution", std::to_string(resolution));
  setup.apply("generator.trees", "4");
  return setup.load();
}

// shadow-map at 256^2 with its default partitions against one map (`one_map`: the parameter that
// keeps it whole): more than `min_partitions` partitions, and at most 0.8 times one map's distance
// from the exact hard shadow.
void expect_partitions_closer_to_hard(const Scene& scene, const std::string& one_map, int min_partitions) {
  const RenderResult hard = render_scene(scene, cpu_settings("hard", {}));
  const RenderResult one = render_scene(scene, cpu_settings("shadow-map", {"resolution=256", one_map}));
  const RenderResult split = render_scene(scene, cpu_settings("shadow-map", {"resolution=256"}));
  EXPECT_EQ(one.stats.extra.value("partitions", 1), 1);
  EXPECT_GT(split.stats.extra.value("partitions", 1), min_partitions);
  const double e_one = testing::mean_abs_dv(one.visibility, hard.visibility);
  const double e_split = testing::mean_abs_dv(split.visibility, hard.visibility);
  EXPECT_LT(e_split, 0.8 * e_one) << e_one << " " << e_split;
}

TEST(LightPartitions, APartitionedShadowMapIsCloserToTheExactHardShadowWhereOneMapCannotHoldTheCasters) {
  expect_partitions_closer_to_hard(small_forest(64), "partitions=1", 4);
}

// The filtered maps split the same way (issue 34): vsm on four trees at 256² maps, against the
// ground truth at the same light samples, is closer with its partitions than as one map.
TEST(LightPartitions, APartitionedVarianceMapIsCloserToTheTruthWhereOneMapCannotHoldTheCasters) {
  const Scene scene = small_forest(64);
  RenderSettings truth_settings = cpu_settings("reference", {});
  truth_settings.light_samples = 256;
  const RenderResult truth = render_scene(scene, truth_settings);
  const RenderResult one = render_scene(scene, cpu_settings("vsm", {"resolution=256", "partitions=1"}));
  const RenderResult split = render_scene(scene, cpu_settings("vsm", {"resolution=256"}));
  EXPECT_EQ(one.stats.extra.value("partitions", 1), 1);
  EXPECT_GT(split.stats.extra.value("partitions", 1), 4);
  const double e_one = testing::mean_abs_dv(one.visibility, truth.visibility);
  const double e_split = testing::mean_abs_dv(split.visibility, truth.visibility);
  std::printf("vsm on four trees against the truth: one map %.4f, %d partitions %.4f\n", e_one,
              split.stats.extra.value("partitions", 1), e_split);
  EXPECT_LT(e_split, 0.9 * e_one) << e_one << " " << e_split;
}

// A long street seen from one end: a 6 x 160 ground with 40 thin posts along it, the camera 2
// above its near end, a far light to the side. Few casters (480 triangles): only the view
// samples' rule can split it.
Scene long_street(int resolution) {
  nlohmann::json objects = nlohmann::json::array();
  objects.push_back({{"shape", "plane"}, {"size", {6, 160}}});
  for (int i = 0; i < 40; ++i)
    objects.push_back({{"shape", "box"}, {"size", {0.05, 1.5, 0.05}}, {"translate", {-1.5 + (i % 3), 0.75, -78 + 4 * i}}});
  const nlohmann::json doc = {
      {"camera", {{"eye", {0, 2, -80}}, {"target", {0, 0.5, -60}}, {"fov_y", 50}, {"resolution", {resolution, resolution}}}},
      {"lights", {{{"type", "rect"}, {"center", {-40, 60, 0}}, {"normal", {0.55, -0.83, 0}}, {"size", {1, 1}}}}},
      {"objects", objects}};
  return parse_scene(doc, PENUMBRA_SOURCE_DIR);
}

TEST(LightPartitions, APartitionedShadowMapIsCloserToTheExactHardShadowWhereTheViewSamplesAreDenserThanTheTexels) {
  expect_partitions_closer_to_hard(long_street(96), "partition_receivers=0", 1);
}

TEST(LightPartitions, NothingIsSplitWhereOneMapHoldsTheCasters) {
  // The bunny: 70 k triangles against 1-4 M texels at each method's partition density (1/16 for
  // shadow-map, mlsm and mtsm, 0.25 for pcss and vsm): one 2048² map holds them at 1/16, one 1024² map at
  // 0.25; at 1/16 a 1024² map (65,536 triangles) does not, and the multilayer maps split.
  const Scene bunny = testing::shipped_scene("bunny.json", 32);
  for (const char* method : {"shadow-map", "pcss", "mlsm", "mtsm", "vsm"}) {
    const bool multilayer = std::string_view(method) == "mlsm" || std::string_view(method) == "mtsm";
    std::vector<std::string> params;
    if (multilayer) params.push_back("resolution=2048");
    const RenderResult r = render_scene(bunny, cpu_settings(method, params));
    EXPECT_EQ(r.stats.extra.value("partitions", 0), 1) << method;
    if (multilayer)
      EXPECT_GT(render_scene(bunny, cpu_settings(method, {})).stats.extra.value("partitions", 0), 1) << method;
  }
}

TEST(LightPartitions, APartitionedMultilayerMapIsAsGoodAsOneOnTheBunny) {
  // Its partitions fit their own receivers' segments toward the light (no guard samples
  // stretching each map to the partition's corners): forced into 4 partitions, the multilayer
  // map stays as close to `reference` at the same light samples as one map is.
  const Scene bunny = testing::shipped_scene("bunny.json", 64);
  const RenderResult ref = render_scene(bunny, cpu_settings("reference", {}));
  const RenderResult one = render_scene(bunny, cpu_settings("mlsm", {"partitions=1"}));
  const RenderResult split = render_scene(bunny, cpu_settings("mlsm", {"partitions=2", "partition_density=0"}));
  EXPECT_EQ(split.stats.extra.value("partitions", 1), 4);
  const double e_one = testing::mean_abs_dv(one.visibility, ref.visibility);
  const double e_split = testing::mean_abs_dv(split.visibility, ref.visibility);
  EXPECT_LT(e_split, 1.15 * e_one) << e_one << " " << e_split;
}

TEST(LightPartitions, ForcedPartitionsCoverEveryViewSampleOnce) {
  // Seven partitions of the bunny's receivers: each sample's V comes from its own partition's
  // map, so the picture stays the one-map picture up to the finer maps' differences (vsm's
  // regions, more texels wide in the finer maps, are also split into more parts: 0.0205).
  const Scene bunny = testing::shipped_scene("bunny.json", 48);
  for (const char* method : {"shadow-map", "mlsm", "vsm"}) {
    const RenderResult one = render_scene(bunny, cpu_settings(method, {"partitions=1"}));
    const RenderResult split = render_scene(bunny, cpu_settings(method, {"partitions=4", "partition_density=0"}));
    EXPECT_GT(split.stats.extra.value("partitions", 1), 4) << method;
    EXPECT_LT(testing::mean_abs_dv(one.visibility, split.visibility), 0.025) << method;
  }
}

class LightPartitionsGpu : public gpu::testing::GpuTest {};

TEST_F(LightPartitionsGpu, PartitionsGiveTheCpuPictures) {
  const Scene bunny = testing::shipped_scene("bunny.json", 40);
  for (const char* method : {"shadow-map", "pcss", "mlsm", "mtsm", "multi-view-sm", "vsm", "evsm", "msm"}) {
    RenderSettings s = testing::device_settings(method, {"partitions=4", "partition_density=0", "resolution=256"},
                                                false, 7, 16);
    const testing::DevicePair pair = testing::render_on_both(bunny, s);
    EXPECT_GT(pair.cpu_shadow, 10) << method;
    EXPECT_LE(pair.mean_abs_dv, 1e-3) << method;
    EXPECT_EQ(pair.gpu.stats.extra.value("partitions", 0), pair.cpu.stats.extra.value("partitions", -1)) << method;
    EXPECT_GT(pair.gpu.stats.extra.value("partitions", 0), 4) << method;
    // Some partitions' views leave the bunny out: the culled casters (raster/caster_culling.h,
    // gpu/raster/object_culling.h) give the same pictures on both devices.
    if (std::string(method) == "shadow-map" || std::string(method) == "pcss" || std::string(method) == "vsm") {
      EXPECT_GT(pair.cpu.stats.extra.value("culled_triangles", uint64_t{0}), 0u) << method;
      EXPECT_GT(pair.gpu.stats.extra.value("culled_triangles", uint64_t{0}), 0u) << method;
    }
    // What the method counts per view sample is summed over the partitions on both devices
    // (MethodStats::add_count on the CPU, one counter buffer per frame on the GPU).
    for (const char* key : {"near_field_rays", "samples_without_blockers"}) {
      if (!pair.cpu.stats.extra.contains(key)) continue;
      const double cpu = pair.cpu.stats.extra[key].get<double>();
      EXPECT_GT(cpu, 0) << method << " " << key;
      EXPECT_NEAR(pair.gpu.stats.extra.value(key, 0.0), cpu, 1e-3 * cpu + 1) << method << " " << key;
    }
  }
  // The view samples' rule alone (no caster splits): the device counts the receivers per cell
  // (partition_occupancy) and makes the CPU's plan from them. At 0.2 samples per texel the root
  // splits (a cell holds more than 12.8) and one quadrant again (more than 51): 7 partitions.
  for (const char* method : {"shadow-map", "pcss"}) {
    RenderSettings s = testing::device_settings(
        method, {"partitions=4", "partition_density=1e6", "partition_receivers=0.2", "resolution=256"}, false, 7, 16);
    const testing::DevicePair pair = testing::render_on_both(bunny, s);
    EXPECT_LE(pair.mean_abs_dv, 1e-3) << method;
    EXPECT_EQ(pair.cpu.stats.extra.value("partitions", 0), 7) << method;
    EXPECT_EQ(pair.gpu.stats.extra.value("partitions", 0), 7) << method;
  }
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra::partitions
