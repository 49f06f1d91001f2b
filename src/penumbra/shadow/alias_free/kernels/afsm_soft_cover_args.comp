#version 460
// afsm on the GPU: the indirect dispatch of one slab's afsm_soft_cover, a thread per covered row
// (the scanned row counts' total, rows[triangles]), folded into two dimensions as
// CommandList::dispatch folds long grids; the rows also add up in the slabs' cover_rows counter.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/alias_free/kernels/afsm_soft_access.glsl"

layout(local_size_x = 1) in;
layout(push_constant, scalar) uniform Push { AfsmSoftParams p; } pc;

const uint kCoverGroup = 64u;  // afsm_soft_cover's local size

void main() {
  uint rows = Uints(pc.p.rows).v[pc.p.triangles];
  uvec3 groups = pn_indirect_groups(rows, kCoverGroup);
  AfsmSlabsRef slabs = afsm_slabs(pc.p.view);
  slabs.s.cover_groups_x = groups.x;
  slabs.s.cover_groups_y = groups.y;
  slabs.s.cover_groups_z = groups.z;
  slabs.s.cover_rows += uint64_t(rows);
}
