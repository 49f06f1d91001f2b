#version 460
// afsm-hard on the GPU, sintorn2008 §3.1 (texel_lists.cpp build_texel_lists, pass 3): one thread
// per view-sample slot; a listed slot takes the next position of its texel's list (first[] holds
// the scanned counts) and keeps that position in its state. The order inside a list is the
// atomics' (the CPU's is the input order): each position's shadow bit depends on its point only.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/alias_free/alias_free_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmHardParams p; } pc;
layout(buffer_reference, scalar) buffer ListedRef { AfsmListed v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.count) return;
  Uints state = Uints(pc.p.state);
  uint texel = state.v[i];
  if (texel >= kAfsmUncovered) return;
  uint pos = Uints(pc.p.first).v[texel] + atomicAdd(Uints(pc.p.cursor).v[texel], 1u);
  AfsmListed l;
  l.p = Vec3s(pc.p.points).v[i];
  l.shadow = 0u;
  ListedRef(pc.p.listed).v[pos] = l;
  state.v[i] = pos;
}
