// What afsm's GPU kernels share: the light block and its samples (AfsmSoftLight, alias_free_shared.h).
#ifndef PENUMBRA_SHADOW_ALIAS_FREE_AFSM_SOFT_ACCESS_GLSL
#define PENUMBRA_SHADOW_ALIAS_FREE_AFSM_SOFT_ACCESS_GLSL

#include "penumbra/gpu/kernel_common.glsl"
#include "penumbra/shadow/alias_free/alias_free_shared.h"

layout(buffer_reference, scalar) buffer AfsmLightRef { AfsmSoftLight l; };
layout(buffer_reference, scalar) buffer AfsmListedRef { AfsmSoftListed v[]; };
layout(buffer_reference, scalar) buffer AfsmSlabsRef { AfsmSlabs s; };

// The slabs' record in the view's buffer: after its RasterView (160 bytes) and AfsmCounters (16).
AfsmSlabsRef afsm_slabs(uint64_t view) { return AfsmSlabsRef(view + 176ul); }

// The histogram bin of a listed depth z (a linear depth in the fitted view, >= near): uniform in
// log depth over [near, far], clamped (listed points lie off the receivers by their ray offset).
uint afsm_depth_bin(float near, float far, float z) {
  float span = log(far / near);
  if (!(span > 1e-6f)) return 0u;
  float t = log(max(z, near) / near) / span;
  return min(uint(max(t, 0.0f) * float(kAfsmDepthBins)), kAfsmDepthBins - 1u);
}

// Light sample k's local coordinates u_k and world point (LightSamples::local, ::points).
vec2 afsm_local(uint64_t light, uint k) { return Vec2s(light + 96ul).v[k]; }
vec3 afsm_point(uint64_t light, uint n, uint k) { return Vec3s(light + 96ul + 8ul * uint64_t(n)).v[k]; }

// Word w (light samples 32 w .. 32 w + 31) of the mask of the samples above the line g . u + h:
// from the table cell `cell` (afsm_lut_cell) and the exact test of its unsure samples, or with
// no table (angle_bins 0) by the exact test of every sample: the same bits (§4.2's lookup).
uint afsm_mask_word(uint64_t light, AfsmSoftLight l, int cell, vec2 g, float h, uint w) {
  uint first = 32u * w, count = min(32u, l.n - first);
  uint valid = count == 32u ? 0xffffffffu : (1u << count) - 1u;
  if (cell == kAfsmLutNone) return 0u;
  if (cell == kAfsmLutAll) return valid;
  uint bits = 0u, unsure = valid;
  if (l.angle_bins != 0u) {
    // The table as uints: cell c's sure bits at c * 4 words64, its unsure ones words64 * 2 later.
    Uints table = Uints(light + 96ul + 20ul * uint64_t(l.n));
    uint words64 = (l.n + 63u) / 64u, base = uint(cell) * 4u * words64;
    bits = table.v[base + w];
    unsure = table.v[base + 2u * words64 + w];
  }
  for (; unsure != 0u; unsure &= unsure - 1u) {
    uint b = uint(findLSB(unsure));
    vec2 u = afsm_local(light, first + b);
    if (afsm_above(u.x, u.y, g, h)) bits |= 1u << b;
  }
  return bits;
}

// The cell of a line for afsm_mask_word (0 without a table: every sample tested).
int afsm_cell(AfsmSoftLight l, vec2 g, float h) {
  if (l.angle_bins == 0u) {
    int side = afsm_side_of_disk(g, h, l.max_distance2);
    return side < 0 ? kAfsmLutNone : side > 0 ? kAfsmLutAll : 0;
  }
  return afsm_lut_cell(g, h, l.max_distance, int(l.angle_bins), int(l.distance_bins));
}

#endif
