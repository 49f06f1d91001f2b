#version 460
// afsm-hard on the GPU: V per view-sample slot from its state and its list position's shadow bit
// (alias_free.cpp AliasFreeHard::evaluate): 0 behind the light or light back-facing on a closed
// mesh, 1 outside the fitted view, else 1 - the bit.
#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/alias_free/alias_free_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { AfsmHardParams p; } pc;
layout(buffer_reference, scalar) readonly buffer ListedIn { AfsmListed v[]; };

void main() {
  uint i = pn_thread_index();
  if (i >= pc.p.count) return;
  uint st = Uints(pc.p.state).v[i];
  if (st == kAfsmMiss) return;
  float v = 1.0f;
  if (st == kAfsmNotListed) v = 0.0f;
  else if (st != kAfsmUncovered) v = ListedIn(pc.p.listed).v[st].shadow != 0u ? 0.0f : 1.0f;
  Floats(pc.p.visibility).v[i] = v;
}
