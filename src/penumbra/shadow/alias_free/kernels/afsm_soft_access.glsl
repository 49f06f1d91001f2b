// What afsm's GPU kernels share: the light block and its samples (AfsmSoftLight, alias_free_shared.h).
#ifndef PENUMBRA_SHADOW_ALIAS_FREE_AFSM_SOFT_ACCESS_GLSL
#define PENUMBRA_SHADOW_ALIAS_FREE_AFSM_SOFT_ACCESS_GLSL

#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/alias_free/alias_free_shared.h"

layout(buffer_reference, scalar) buffer AfsmLightRef { AfsmSoftLight l; };
layout(buffer_reference, scalar) buffer AfsmListedRef { AfsmSoftListed v[]; };

// Light sample k's local coordinates u_k and world point (LightSamples::local, ::points).
vec2 afsm_local(uint64_t light, uint k) { return Vec2s(light + 80ul).v[k]; }
vec3 afsm_point(uint64_t light, uint n, uint k) { return Vec3s(light + 80ul + 8ul * uint64_t(n)).v[k]; }

#endif
