// What `lam`'s precompute kernels share (lam_kernels_shared.h): a light sample's depth map read
// from the GPU rasterizer's keys, and the splat of one of its pixels (lam_shared.h, the CPU's).
#ifndef PENUMBRA_SHADOW_LAM_LAM_ACCESS_GLSL
#define PENUMBRA_SHADOW_LAM_LAM_ACCESS_GLSL

#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/raster/raster_shared.h"
#include "penumbra/shadow/lam/lam_kernels_shared.h"

// The depth of texel (x, y) of the sample's map (`keys`: its first key): +inf outside it or where
// empty.
float lam_sample_depth(Uint64s keys, LamSampleView sv, int x, int y) {
  if (x < 0 || y < 0 || x >= sv.width || y >= sv.height) return pn_inf();
  uint64_t key = keys.v[uint(y) * uint(sv.width) + uint(x)];
  return key == ~0UL ? pn_inf() : raster_key_depth(key);
}

// The splat of pixel (x, y) at depth z of the sample's map into the W x H reference view
// (attenuation_map.cpp Builder's warp: lam_warp, then lam_splat with the neighbours' depths).
// False when it touches no reference texel.
bool lam_pixel_splat(Uint64s keys, LamSampleView sv, int x, int y, float z, int W, int H, bool slope,
                     out LamSplat s) {
  float fx, fy;
  int ix, iy;
  if (!lam_warp(x, y, z, sv.ox, sv.oy, sv.bx, sv.by, W, H, fx, fy, ix, iy)) return false;
  s = lam_splat(z, lam_sample_depth(keys, sv, x - 1, y), lam_sample_depth(keys, sv, x + 1, y),
                lam_sample_depth(keys, sv, x, y - 1), lam_sample_depth(keys, sv, x, y + 1), sv.bx, sv.by, fx, fy, ix,
                iy, slope);
  return true;
}

#endif
