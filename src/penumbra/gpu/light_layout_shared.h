// A light on the GPU, 128 bytes (scalar layout), written by gpu/gpu_light.cpp:
//   bytes 0-79 geometry (scene/light_shared.h LightGeometry)   80-91 radiance   92-95 textured
//   bytes 96-103 marginal   104-111 conditional: the addresses of its texture's sampling table
//                (PiecewiseConstant2D of its colour channel: height + 1 and height x (width + 1)
//                floats), 0 for an untextured light
//   bytes 112-115 table_width   116-119 table_height   120-127 (unused, 0)
#ifndef PENUMBRA_GPU_LIGHT_LAYOUT_SHARED_H
#define PENUMBRA_GPU_LIGHT_LAYOUT_SHARED_H

#include "penumbra/core/shader_compat.h"
#include "penumbra/scene/light_shared.h"

PN_SHARED_BEGIN

struct GpuLight {
  LightGeometry geometry;
  vec3 radiance;
  uint textured;
  uint64_t marginal;
  uint64_t conditional;
  int table_width;
  int table_height;
  uint pad0;
  uint pad1;
};

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::GpuLight) == 128);
#endif

#endif  // PENUMBRA_GPU_LIGHT_LAYOUT_SHARED_H
