#version 460
// Light-space partitions, step 2 on the device (partitions/light_partitions_gpu.cpp): one thread
// per view-sample slot; its partition (the plan's leaf of its grid cell; a hit that is no
// receiver joins partition 0, as on the CPU; a miss none: ~0u) and the partitions' sizes.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/partitions/light_partitions_shared.h"
#include "penumbra/shadow/shadow_map_shared.h"
#include "penumbra/shadow/view_samples_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { PartitionClassifyParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) readonly buffer GridRef { PartitionGrid g; };
layout(buffer_reference, scalar) readonly buffer IntsIn { int v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.slots) return;
  GpuViewSample s = ViewSamplesIn(pc.p.samples).v[i];
  uint leaf = 0xffffffffu;
  if (s.object != kMissObject) {
    leaf = 0u;
    if (sm_in_front_of_light(pc.p.light_center, pc.p.light_n, s.p)) {
      int cell = partition_cell(GridRef(pc.p.grid).g, pc.p.cells, s.p);
      int l = cell >= 0 ? IntsIn(pc.p.leaf_of_cell).v[cell] : -1;
      leaf = l >= 0 ? uint(l) : 0u;
    }
    atomicAdd(Uints(pc.p.counts).v[leaf], 1u);
  }
  Uints(pc.p.leaf).v[i] = leaf;
}
