// fit_shadow_view's per-receiver step in the common subset of C++ and GLSL (core/shader_compat.h):
// a receiver's position in the view frame as the fit reduces it (x/z, y/z and z). The CPU
// reduces with min and max (raster/shadow_view.cpp reduce_receivers); the GPU with atomic min and
// max of raster_order_bits (gpu/raster/kernels/fit_receivers.comp), which give the same floats;
// both then build the view with the same host code (build_shadow_view).
#ifndef PENUMBRA_RASTER_SHADOW_VIEW_SHARED_H
#define PENUMBRA_RASTER_SHADOW_VIEW_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// The fitted view's frame, 64 bytes: bytes 0-11 eye, 12-15 min_near (nothing nearer is fitted),
// 16-27 right, 32-43 up, 48-59 forward (LightView's axes); 28-31, 44-47, 60-63 unused (0).
struct ShadowViewAxes {
  vec3 eye;
  float min_near;
  vec3 right;
  float pad0;
  vec3 up;
  float pad1;
  vec3 forward;
  float pad2;
};

// The receiver p in the view frame: false when it lies nearer than min_near (it is ignored),
// else x/z, y/z and its linear depth z.
PN_INLINE bool shadow_view_project(ShadowViewAxes a, vec3 p, PN_OUT(float) x, PN_OUT(float) y, PN_OUT(float) z) {
  vec3 d = p - a.eye;
  z = dot(d, a.forward);
  x = 0.0f;
  y = 0.0f;
  if (!(z >= a.min_near)) return false;
  x = dot(d, a.right) / z;
  y = dot(d, a.up) / z;
  return true;
}

PN_SHARED_END

#ifdef __cplusplus
static_assert(sizeof(penumbra::shader::ShadowViewAxes) == 64);
#endif

#endif  // PENUMBRA_RASTER_SHADOW_VIEW_SHARED_H
