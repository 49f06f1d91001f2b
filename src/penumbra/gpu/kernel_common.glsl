// What every penumbra kernel starts with (#include "penumbra/gpu/kernel_common.glsl" right
// after #version): the extensions the device layer enables (gpu/device.h), and the thread
// index of a 1D dispatch that CommandList::dispatch may have folded into a 2D grid.
#ifndef PENUMBRA_GPU_KERNEL_COMMON_GLSL
#define PENUMBRA_GPU_KERNEL_COMMON_GLSL

#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_explicit_arithmetic_types_int8 : require
#extension GL_EXT_shader_8bit_storage : require
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_buffer_reference2 : require
#extension GL_EXT_scalar_block_layout : require

// The global index of this thread in a 1D dispatch of N threads (check it against N: the last
// group runs past it). A macro, not a function: this file comes before the kernel's
// `layout(local_size_x = ...) in;`, and glslang gives gl_WorkGroupSize its default (1, 1, 1) in a
// function defined above that declaration, so a function here numbered the threads of a folded
// grid's second row from 65535 instead of 65535 x the group size: duplicates and gaps past
// 65535 groups (ssv-rt at 480x270: wrong on lavapipe, no frame on an H200;
// GpuTest.AFoldedGridNumbersEveryThreadOnce).
#define pn_thread_index() (gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x)

// The group counts (x, y, z) of an indirect dispatch of `threads` threads in groups of `local`,
// folded into two dimensions as CommandList::dispatch folds long grids (kMaxGroupsX in
// gpu/commands.cpp; pn_thread_index unfolds them). No threads: no groups.
uvec3 pn_indirect_groups(uint threads, uint local) {
  const uint kMaxGroupsX = 65535u;
  uint groups = (threads + local - 1u) / local;
  return uvec3(min(groups, kMaxGroupsX), (groups + kMaxGroupsX - 1u) / kMaxGroupsX, 1u);
}

float pn_inf() { return uintBitsToFloat(0x7f800000u); }

// True when the driver's loop limit cut this invocation's loops short (lavapipe: 65535 loop
// iterations per invocation, all loops counted together, past which every loop stops without an
// error; docs/gpu.md). Call it last, with `canary` a push constant of 2 (a constant the compiler
// would unroll): once the limit was hit its loop runs once. gpu/loop_limit.h splits the work.
bool pn_loop_limit_hit(int canary) {
  int ran = 0;
  for (int k = 0; k < canary; ++k) ran += 1;
  return ran != canary;
}

// Buffer references every kernel may use: a buffer is its device address (gpu/buffer.h).
layout(buffer_reference, scalar) buffer Floats { float v[]; };
layout(buffer_reference, scalar) buffer Uints { uint v[]; };
layout(buffer_reference, scalar) buffer Uint64s { uint64_t v[]; };
layout(buffer_reference, scalar) buffer Vec2s { vec2 v[]; };
layout(buffer_reference, scalar) buffer Vec3s { vec3 v[]; };
layout(buffer_reference, scalar) buffer Vec4s { vec4 v[]; };

#endif
