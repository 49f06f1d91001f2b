#version 460
// Light-space partitions, the last step on the device (partitions/light_partitions_gpu.cpp): one
// thread per compact sample; its V (and E) back into its slot. Guard samples (slot ~0u) are
// dropped.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/partitions/light_partitions_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { PartitionScatterParams p; } pc;

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.count) return;
  uint slot = Uints(pc.p.slot_of).v[i];
  if (slot == 0xffffffffu) return;
  Floats(pc.p.visibility).v[slot] = Floats(pc.p.part_visibility).v[i];
  if (pc.p.irradiance != 0UL) Vec3s(pc.p.irradiance).v[slot] = Vec3s(pc.p.part_irradiance).v[i];
}
