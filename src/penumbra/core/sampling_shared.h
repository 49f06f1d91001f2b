// The sampling warps both devices use (core/sampling.h on the CPU, the GPU kernels), in the
// common subset of C++ and GLSL (core/shader_compat.h): stratified cells, the concentric disk,
// the uniform cone, and the inversion of a piecewise-constant CDF (textured lights).
#ifndef PENUMBRA_CORE_SAMPLING_SHARED_H
#define PENUMBRA_CORE_SAMPLING_SHARED_H

#include "penumbra/core/shader_compat.h"

PN_SHARED_BEGIN

PN_CONST float kPiShared = 3.14159265358979323846f;

// Cell i (row by row) of a cols x rows stratification jittered by u in [0,1)^2
// (StratifiedGrid::sample; inv_cols = 1 / cols, inv_rows = 1 / rows).
PN_INLINE vec2 stratified_cell(int i, int cols, float inv_cols, float inv_rows, vec2 u) {
  int cx = i % cols;
  int cy = i / cols;
  return vec2((float(cx) + u.x) * inv_cols, (float(cy) + u.y) * inv_rows);
}

// Shirley-Chiu concentric map from [0,1)^2 to the unit disk: keeps strata compact.
PN_INLINE vec2 concentric_disk(vec2 u) {
  float ox = 2.0f * u.x - 1.0f;
  float oy = 2.0f * u.y - 1.0f;
  if (ox == 0.0f && oy == 0.0f) return vec2(0.0f, 0.0f);
  float r;
  float theta;
  if (abs(ox) > abs(oy)) {
    r = ox;
    theta = (kPiShared / 4.0f) * (oy / ox);
  } else {
    r = oy;
    theta = (kPiShared / 2.0f) - (kPiShared / 4.0f) * (ox / oy);
  }
  return vec2(r * pn_cos(theta), r * pn_sin(theta));
}

// The inverse of concentric_disk: the point of [0,1)^2 that maps to d (|d| < 1). Shirley-Chiu's
// wedges: where |d.x| >= |d.y| the square's ox = sign(d.x) |d|, theta = atan(d.y / d.x) = pi/4
// oy / ox; elsewhere oy = sign(d.y) |d|, atan(d.x / d.y) = pi/4 ox / oy. Neighbouring cells of
// the square stay neighbours on the disk, its border is the rim: coherent-rt's light cells on a
// disk light (soft_shad_shared.h ss_project).
PN_INLINE vec2 concentric_square(vec2 d) {
  float r = sqrt(d.x * d.x + d.y * d.y);
  if (r == 0.0f) return vec2(0.5f, 0.5f);
  float ox;
  float oy;
  if (abs(d.x) >= abs(d.y)) {
    ox = d.x > 0.0f ? r : -r;
    float theta = float(atan2_double(double(d.y), double(abs(d.x)))) * (d.x > 0.0f ? 1.0f : -1.0f);
    oy = ox * theta * (4.0f / kPiShared);
  } else {
    oy = d.y > 0.0f ? r : -r;
    float theta = float(atan2_double(double(d.x), double(abs(d.y)))) * (d.y > 0.0f ? 1.0f : -1.0f);
    ox = oy * theta * (4.0f / kPiShared);
  }
  return vec2(0.5f * (ox + 1.0f), 0.5f * (oy + 1.0f));
}

// Uniform direction inside a cone of half-angle acos(cos_max) around +z.
PN_INLINE vec3 uniform_cone(vec2 u, float cos_max) {
  float cos_t = (1.0f - u.x) + u.x * cos_max;
  float sin_t = sqrt(max(0.0f, 1.0f - cos_t * cos_t));
  float phi = 2.0f * kPiShared * u.y;
  return vec3(pn_cos(phi) * sin_t, pn_sin(phi) * sin_t, cos_t);
}
PN_INLINE float uniform_cone_pdf(float cos_max) { return 1.0f / (2.0f * kPiShared * (1.0f - cos_max)); }

// Inverts the CDF cdf[first .. first + n] (n cells, from 0 to 1) at u: the cell i with
// cdf[i] <= u < cdf[i + 1] (std::upper_bound's) and (i + position in it) / n.
PN_INLINE float invert_cdf(PN_FLOAT_ARRAY cdf, uint first, int n, float u, PN_OUT(int) cell) {
  int lo = 0;
  int count = n + 1;
  while (count > 0) {  // the first entry greater than u
    int step = count / 2;
    int it = lo + step;
    if (!(u < PN_AT(cdf, first + uint(it)))) {
      lo = it + 1;
      count -= step + 1;
    } else {
      count = step;
    }
  }
  int i = lo - 1 < 0 ? 0 : (lo - 1 > n - 1 ? n - 1 : lo - 1);
  float c0 = PN_AT(cdf, first + uint(i));
  float width = PN_AT(cdf, first + uint(i) + 1u) - c0;
  float t = width > 0.0f ? clamp((u - c0) / width, 0.0f, 1.0f) : 0.5f;
  cell = i;
  return (float(i) + t) / float(n);
}

// PiecewiseConstant2D::sample: a row by the marginal CDF (height + 1 entries), then a column by
// that row's conditional CDF (rows of width + 1 entries).
PN_INLINE vec2 piecewise_constant_2d_sample(PN_FLOAT_ARRAY marginal, PN_FLOAT_ARRAY conditional, int width,
                                           int height, vec2 u) {
  int row = 0;
  int col = 0;
  float v = invert_cdf(marginal, 0u, height, u.y, row);
  float x = invert_cdf(conditional, uint(row) * uint(width + 1), width, u.x, col);
  return vec2(x, v);
}

PN_SHARED_END

#endif  // PENUMBRA_CORE_SAMPLING_SHARED_H
