// Texture lookups in the common subset of C++ and GLSL (core/shader_compat.h): the four texels
// around a texture coordinate and their bilinear weights, for Texture (scene/texture.h) and for
// the GPU's texel arrays (gpu/scene_layout_shared.h), so both devices look up the same texels.
#ifndef PENUMBRA_SCENE_TEXTURE_SHARED_H
#define PENUMBRA_SCENE_TEXTURE_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

// Texel indices (row-major, row 0 at the top) and weights of a bilinear lookup.
struct TexelFootprint {
  uint i0, i1, i2, i3;
  float w0, w1, w2, w3;
};

// texture.h's conventions: (0, 0) is the image's bottom-left corner, coordinates repeat, and
// lookups are bilinear between texel centres. With u, v in [0, 1) the texel coordinates lie in
// [-1, n]: one conditional step wraps them (GLSL's % is undefined for negative operands).
PN_INLINE int wrap_texel(int i, int n) { return i < 0 ? i + n : (i >= n ? i - n : i); }

PN_INLINE TexelFootprint texel_footprint(vec2 uv, int width, int height) {
  float u = uv.x - floor(uv.x);
  float v = uv.y - floor(uv.y);
  float x = u * float(width) - 0.5f;
  float y = (1.0f - v) * float(height) - 0.5f;
  float fx = floor(x);
  float fy = floor(y);
  float tx = x - fx;
  float ty = y - fy;
  int x0 = wrap_texel(int(fx), width);
  int x1 = wrap_texel(int(fx) + 1, width);
  int y0 = wrap_texel(int(fy), height);
  int y1 = wrap_texel(int(fy) + 1, height);
  TexelFootprint f;
  f.i0 = uint(y0 * width + x0);
  f.i1 = uint(y0 * width + x1);
  f.i2 = uint(y1 * width + x0);
  f.i3 = uint(y1 * width + x1);
  f.w0 = (1.0f - tx) * (1.0f - ty);
  f.w1 = tx * (1.0f - ty);
  f.w2 = (1.0f - tx) * ty;
  f.w3 = tx * ty;
  return f;
}

PN_SHARED_END

#endif  // PENUMBRA_SCENE_TEXTURE_SHARED_H
