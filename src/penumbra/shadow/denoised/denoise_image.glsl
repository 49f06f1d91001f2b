// What rt-denoised's filter kernels share (denoised_kernels_shared.h): the planes record, and a
// slot's image (its camera-ray index's) and pixel.
#ifndef PENUMBRA_SHADOW_DENOISED_DENOISE_IMAGE_GLSL
#define PENUMBRA_SHADOW_DENOISED_DENOISE_IMAGE_GLSL

#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/core/shader_compat_math.h"
#include "penumbra/shadow/denoised/atrous_shared.h"
#include "penumbra/shadow/denoised/denoised_kernels_shared.h"

layout(buffer_reference, scalar) readonly buffer DnPlanesRef { DnPlanes p; };

// The image slot `slot` belongs to, with S, U, A and the variance of set `current`, and the slot's
// pixel (x, y) in it.
DenoiseImage dn_slot_image(DnPlanes planes, DnFilterParams p, uint slot, out int x, out int y) {
  uint spp = uint(p.spp);
  uint pixel = slot / spp;
  x = int(pixel % uint(p.width));
  y = int(pixel / uint(p.width));
  DenoiseImage img;
  img.width = p.width;
  img.height = p.height;
  img.pixel_stride = spp;
  img.pixel_offset = slot % spp;
  img.valid = Bytes(planes.valid);
  img.depth = Floats(planes.depth);
  img.normal = Vec3s(planes.normal);
  img.shadowed = Floats(planes.shadowed[p.current]);
  img.unshadowed = Floats(planes.unshadowed[p.current]);
  img.area = Floats(planes.area[p.current]);
  img.variance = Floats(planes.variance[p.current]);
  return img;
}

DenoiseSettings dn_settings(DnFilterParams p) {
  DenoiseSettings s;
  s.sigma_z = p.sigma_z;
  s.sigma_n = p.sigma_n;
  s.sigma_l = p.sigma_l;
  return s;
}

#endif
