#version 460
// Light-space partitions, step 1 on the device (partitions/light_partitions_gpu.cpp): one thread
// per view-sample slot; a receiver (a hit in front of the light) counts in its grid cell.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/partitions/light_partitions_shared.h"
#include "penumbra/shadow/shadow_map_shared.h"
#include "penumbra/shadow/view_samples_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { PartitionClassifyParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer GridRef { PartitionGrid g; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.slots) return;
  GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
  if (s.object == kMissObject || !(sm_in_front_of_light(pc.p.light_center, pc.p.light_n, s.p))) return;
  int cell = partition_cell(GridRef(pc.p.grid).g, pc.p.cells, s.p);
  if (cell >= 0) atomicAdd(Uints(pc.p.occupancy).v[cell], 1u);
}
