// Light-space partitions (issue 34, part 1): where one map fitted to the view samples cannot
// hold the casters it covers, the view samples are split by where they lie in light space and
// the method renders each part on its own, its map fitted tightly to that part alone, as sample
// distribution shadow maps fit each partition (Lauritzen et al. 2011, "Sample Distribution
// Shadow Maps", §3-4). docs/methods/shadow-map.md ("Wide scenes") says what and why.
//
// The plan. The receivers (view samples in front of the light) are projected from the light's
// centre along its normal (raster/shadow_view_shared.h shadow_view_project); their x/z, y/z
// bounds are the root rectangle. A quadtree over it splits a node while (1) some receiver falls
// in it, (2) more caster triangles project into it (their centroids) than `density` times the
// map's texels, or more receivers fall into one of its grid cells than `receiver_density` times
// the texels a map of the node would give that cell, and (3) it is above the deepest level
// `partitions` allows. Its leaves that hold receivers are the partitions. The first rule follows
// the casters: a dense forest under a far light gets many small partitions, a single object (the
// bunny: 70 k triangles in a 1024^2 map) none. The second follows the view samples, as sample
// distribution shadow maps do: where the camera sees a part of light space from near, its
// samples are denser there than one map's texels (the near end of a street 128 m long), and that
// part gets maps of its own.
//
// Each partition is rendered as a frame of its own: its view samples, plus four guard samples
// at the corners of its rectangle widened by the blocker search margin of xie2007 eq. 1 (a point
// at depth z_r sees casters at depth >= z_min within light_radius (1/z_min - 1/z_r) of its own
// x/z, y/z), so the partition's fitted map also holds the casters its points' penumbrae reach
// into from beyond the partition's edge. Guard samples are evaluated and dropped. They are kept
// within 90% of the method's max_fov, so that a partition whose own receivers all lie beyond it
// (where every method counts them lit) still has something to fit to.
//
// The wrapper serves any method that fits its light-space structures to the view samples it is
// given (shadow-map, pcss, mlsm, mtsm, multi-view-sm, vsm, evsm, msm); the GPU version
// (light_partitions_gpu.h) makes the same plan from the same numbers.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "penumbra/raster/shadow_view.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadow/params.h"
#include "penumbra/shadow/partitions/light_partitions_shared.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/shadow/view_samples.h"

namespace penumbra::partitions {

// Caster triangles per texel of a map at which a partition splits, by default: four texels a
// triangle (kSamplingDensity), where a filtered map (pcss) samples each caster's shadow; sixteen
// (kResolvingDensity, a 4 x 4-texel footprint), where a map that is the shadow itself (shadow-map's
// hard shadow, the multilayer maps' rays) resolves a canopy's leaves where they cross (issue 34:
// shadow-map below `hard` on forests of 16, 25 and 36 trees, mlsm's error 30% lower, at two to
// three times the forest's time; the bunny's 70 k triangles stay one 2048² shadow-map and split
// mlsm's 1024² maps in a few, for the same error at 8% more time).
inline constexpr double kSamplingDensity = 0.25;
inline constexpr double kResolvingDensity = 1.0 / 16;

// The parameters `partitions` (most partitions a side, a power of two: 1 = one map, the
// method's own), `partition_density` and `partition_receivers`, appended to a method's table.
std::vector<ParamSpec> param_specs(int default_partitions = 8, double default_density = kSamplingDensity,
                                   double default_receivers = 1.0);

// Where a partition gets guard samples. AtTheMargin: always, at the corners of its rectangle
// widened by the blocker-search margin (its map must hold the casters its points' penumbrae reach
// into from beyond its edge). OnlyToFit: for a method whose own fit already holds every
// receiver-to-light segment (the multilayer maps' push-back, multilayer_map.h
// light_centre_view): only in a partition none of whose occupied cells lies wholly within 90% of
// max_fov, so that it has something to fit to; elsewhere guards would only widen its map
// (the bunny's partitions at 256^2 went from a 30 to a 60 degree half field of view).
enum class GuardSamples { AtTheMargin, OnlyToFit };

struct Settings {
  int max_side = 8;       // partitions: the quadtree's deepest level has max_side^2 cells
  float density = 0.25f;  // a node splits while its casters exceed density x the map's texels
  // ... or while one of its grid cells holds more receivers than receiver_density x the texels a
  // map fitted to the node would give that cell (map_texels / the node's cells); 0: never
  float receiver_density = 1.0f;
  int map_texels = 1 << 20;  // the method's map: resolution^2
  float max_fov = 120.0f;    // the method's: guard samples stay inside it
  GuardSamples guards = GuardSamples::AtTheMargin;
};
Settings settings_from(const ParamSet& p, int map_resolution);

// The light-centre frame the plan projects in (shadow_view_frame from the light's centre along
// its normal, its min_near from the scene's bounds).
ShadowViewFrame light_frame(const AreaLight& light, const Bounds3f& scene_bounds);

// The casters' centroids in the light-centre frame (x/z, y/z, z), those in front of it.
struct CasterCentroids {
  std::vector<Vec3f> xyz;
  float z_min = kInfinity;  // the nearest caster vertex's depth
  void gather(const Scene& scene, const ShadowViewFrame& frame);
};

// The receivers as the plan needs them: their bounds, depth range and how many fall in each
// grid cell.
struct ReceiverGrid {
  ShadowViewRange range;
  int grid = 0;
  std::vector<uint32_t> counts;  // grid^2: the receivers in each cell
};

struct Plan {
  int grid = 1;  // cells a side: max_side x 8 (at least 8), so a leaf is 8+ cells
  shader::PartitionGrid g{};
  std::vector<int32_t> leaf_of_cell;  // grid^2, -1: no partition
  int leaves = 0;
  // Each leaf's four guard points (world space): the corners of its rectangle widened by the
  // blocker search margin, at the deepest receiver's depth; and whether the leaf gets them
  // (Settings::guards).
  std::vector<std::array<Vec3f, 4>> guards;
  std::vector<uint8_t> guarded;
  int guard_count(int leaf) const { return guarded[leaf] ? 4 : 0; }
  bool split() const { return leaves > 1; }
};

// The grid the plan cuts, before the receivers are known in cells: the root rectangle from
// their range (widened by a hair so the extremes fall inside).
shader::PartitionGrid grid_over(const ShadowViewFrame& frame, const ShadowViewRange& range, int grid);
// Whether the receivers alone could split the root: `view_samples` (at most that many
// receivers) more than receiver_density x the texels of one of the root's cells.
bool receivers_could_split(uint64_t view_samples, const Settings& settings);
// Whether a frame of `view_samples` could split: partitions > 1, and more casters than the
// density allows in all or receivers_could_split. When not (a single object seen by a small
// image), the wrappers hand the frame to the method untouched, without even reducing the
// receivers.
bool could_split(const CasterCentroids& casters, const Settings& settings, uint64_t view_samples);
// Whether the root can split at all: receivers_could_split, or more casters project into the
// receivers' range than the density allows (and partitions > 1). When not, the plan is one
// partition and the receivers' grid is not needed.
bool may_split(const ShadowViewFrame& frame, const ShadowViewRange& receivers, const CasterCentroids& casters,
               const Settings& settings, uint64_t view_samples);
// The plan from the receivers and the casters (the same on both devices).
Plan make_plan(const ShadowViewFrame& frame, const ReceiverGrid& receivers, const CasterCentroids& casters,
               const AreaLight& light, const Settings& settings);
// Cells a side for these settings.
int grid_cells(const Settings& settings);

// What the wrapper holds, added to a method's `tally` (nothing with `partitions` = 1): the
// casters' centroids, and a partition's copy of its view samples with their V and E.
void add_memory(MemoryTally& tally, const ParamSet& p, const MemoryQuery& q);

// A method that fits to its view samples, rendered partition by partition. With one partition
// it is the wrapped method itself.
std::unique_ptr<ShadowMethod> wrap(std::unique_ptr<ShadowMethod> inner, const ParamSet& p, int map_resolution,
                                   GuardSamples guards = GuardSamples::AtTheMargin);

}  // namespace penumbra::partitions
