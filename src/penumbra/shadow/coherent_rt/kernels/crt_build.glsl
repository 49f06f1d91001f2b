// What the reference-image kernels share (coherent_rt_kernels_shared.h): their parameters and
// the texel planes as reference_images_shared.h reads them.
#ifndef PENUMBRA_SHADOW_COHERENT_RT_KERNELS_CRT_BUILD_GLSL
#define PENUMBRA_SHADOW_COHERENT_RT_KERNELS_CRT_BUILD_GLSL

#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/gpu/raster/raster_access.glsl"  // RasterViewRef; raster_source for crt_floors
#include "penumbra/shadow/coherent_rt/coherent_rt_kernels_shared.h"

layout(local_size_x = 64) in;
layout(push_constant, scalar) uniform Push { CrtBuildParams p; } pc;

CrtTexelsRef build_texels() {
  CrtTexelsRef t;
  t.z = pc.p.z;
  t.triangle = pc.p.triangle;
  t.links = pc.p.links;
  t.floors = pc.p.floors;
  t.width = pc.p.width;
  t.height = pc.p.height;
  return t;
}

#endif
