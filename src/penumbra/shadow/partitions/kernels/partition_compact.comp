#version 460
// Light-space partitions, step 3 on the device (partitions/light_partitions_gpu.cpp): one thread
// per view-sample slot; a sample of partition L is copied into L's run of the compact list and
// its slot recorded there (the order within a run is the atomics'; every result is per sample).
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/partitions/light_partitions_shared.h"
#include "penumbra/shadow/view_samples_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { PartitionCompactParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ViewSamplesIn { GpuViewSample v[]; };
layout(buffer_reference, scalar) writeonly buffer ViewSamplesOut { GpuViewSample v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.slots) return;
  uint leaf = Uints(pc.p.leaf).v[i];
  if (leaf == 0xffffffffu) return;
  uint at = Uints(pc.p.first).v[leaf] + atomicAdd(Uints(pc.p.fill).v[leaf], 1u);
  ViewSamplesOut(pc.p.compact).v[at] = ViewSamplesIn(pc.p.samples).v[i];
  Uints(pc.p.slot_of).v[at] = i;
}
