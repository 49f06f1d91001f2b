// Light-space partitions (shadow/partitions/light_partitions.h) on the device, byte by byte:
// which partition a view sample belongs to, and the kernels that split a frame's view samples
// into one compact list per partition and put each partition's V (and E) back into its slots
// (partitions/kernels/partition_*.comp). Common subset of C++ and GLSL (core/shader_compat.h),
// scalar block layout.
//
// A view sample's place in light space is its projection in the light-centre frame
// (raster/shadow_view_shared.h shadow_view_project: x/z, y/z from the light's centre along its
// normal). The plan's root rectangle [x0, x1] x [y0, y1] is cut into grid x grid cells; each cell
// belongs to one partition (a leaf of the plan's quadtree) or to none (-1: no receiver there).
#ifndef PENUMBRA_SHADOW_PARTITIONS_LIGHT_PARTITIONS_SHARED_H
#define PENUMBRA_SHADOW_PARTITIONS_LIGHT_PARTITIONS_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/raster/shadow_view_shared.h"

PN_SHARED_BEGIN

// The grid over the root rectangle, 80 bytes: the light-centre axes (raster/shadow_view_shared.h,
// 64 bytes), then x0, y0 (bytes 64-71), the cells per unit of x/z and y/z (72-79).
struct PartitionGrid {
  ShadowViewAxes axes;
  float x0;
  float y0;
  float cells_per_x;
  float cells_per_y;
};

// The grid cell of a point (clamped to the grid), or -1 when it lies behind the light-centre
// frame's near plane.
PN_INLINE int partition_cell(PartitionGrid g, int grid, vec3 p) {
  float x, y, z;
  if (!shadow_view_project(g.axes, p, x, y, z)) return -1;
  int cx = int(clamp(floor((x - g.x0) * g.cells_per_x), 0.0f, float(grid - 1)));
  int cy = int(clamp(floor((y - g.y0) * g.cells_per_y), 0.0f, float(grid - 1)));
  return cy * grid + cx;
}

// partition_occupancy.comp and partition_assign.comp: one thread per view-sample slot.
//   occupancy: uint[grid^2], the receivers in each cell (partition_occupancy)
//   leaf_of_cell: int[grid^2] (the plan), leaf: uint[slots] out (~0u: none), counts: uint[leaves]
//   (partition_assign)
struct PartitionClassifyParams {
  uint64_t grid;          // PartitionGrid
  uint64_t samples;       // GpuViewSample[slots]
  uint64_t occupancy;     // partition_occupancy: uint[grid^2]
  uint64_t leaf_of_cell;  // partition_assign: int[grid^2]
  uint64_t leaf;          // partition_assign: uint[slots]
  uint64_t counts;        // partition_assign: uint[leaves]
  vec3 light_center;      // receivers: dot(p - light_center, light_n) > 0, as the methods' fits
  uint slots;
  vec3 light_n;
  int cells;  // the grid's cells a side
};

// partition_compact.comp: one thread per slot; a sample of leaf L goes to
// compact[first[L] + atomicAdd(fill[L], 1)] and its slot to slot_of[the same index].
struct PartitionCompactParams {
  uint64_t samples;  // GpuViewSample[slots]
  uint64_t leaf;     // uint[slots]
  uint64_t first;    // uint[leaves]: each leaf's first index in compact
  uint64_t fill;     // uint[leaves], zeroed
  uint64_t compact;  // GpuViewSample[]
  uint64_t slot_of;  // uint[]
  uint slots;
  uint pad;
};

// partition_scatter.comp: one thread per compact sample (guard samples excluded):
// visibility[slot_of[i]] = part_visibility[i], and E likewise when irradiance != 0.
struct PartitionScatterParams {
  uint64_t slot_of;
  uint64_t part_visibility;
  uint64_t visibility;
  uint64_t part_irradiance;  // vec3[]; 0: none
  uint64_t irradiance;
  uint count;
  uint pad;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::PartitionGrid) == 80);
static_assert(sizeof(penumbra::shader::PartitionClassifyParams) <= 128);
static_assert(sizeof(penumbra::shader::PartitionCompactParams) <= 128);
static_assert(sizeof(penumbra::shader::PartitionScatterParams) <= 128);
#endif

#endif  // PENUMBRA_SHADOW_PARTITIONS_LIGHT_PARTITIONS_SHARED_H
