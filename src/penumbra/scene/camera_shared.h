// The camera's rays in the common subset of C++ and GLSL (core/shader_compat.h): the direction
// through an image position, for CameraProjection (scene/camera.h) and the GPU's camera pass.
#ifndef PENUMBRA_SCENE_CAMERA_SHARED_H
#define PENUMBRA_SCENE_CAMERA_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// Unit direction through image position (px, py) in pixels ((0, 0) the top-left corner, y
// downward) of a pinhole camera with frame (s right, t up, n backward), tan of half its vertical
// field of view, and aspect = width / height.
PN_INLINE vec3 camera_ray_direction(vec3 s, vec3 t, vec3 n, float tan_half, float aspect, float width, float height,
                                    float px, float py) {
  float x = (2.0f * px / width - 1.0f) * tan_half * aspect;
  float y = (1.0f - 2.0f * py / height) * tan_half;
  return normalize(s * x + t * y - n);
}

PN_SHARED_END

#endif  // PENUMBRA_SCENE_CAMERA_SHARED_H
