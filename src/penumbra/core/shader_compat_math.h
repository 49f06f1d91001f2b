// More of the common subset of C++ and GLSL (core/shader_compat.h states the rules): what the
// filtered maps (raster/filtered_map_shared.h), the moment models (shadow/filtered_moments/
// moments_shared.h), the occlusion textures' lookups and the a-trous filter need beyond it.
// Every name here is pn_-prefixed, so this header adds to shader_compat.h without clashing.
//
// - Doubles: pn_dmin, pn_dmax, pn_dfloor, pn_disfinite, and exp and log in double (pn_exp_d, pn_log_d). GLSL
//   has exp and log in float only; the GPU side is Cephes' exp and log (range reduction by ln 2,
//   a rational approximation; within 1 ulp of libm over the moments' range, shared_functions
//   test), the CPU side libm's.
// - Floats: pn_expf and pn_powf through the double ones on the GPU (libm's on the CPU: within an
//   ulp either way, so the floats agree but near rounding ties), pn_log2f and pn_ceilf the
//   built-ins (Vulkan lets log2 be a few ulps from libm: the mip chain's level of detail moves by
//   that much).
// - Arrays beyond PN_FLOAT_ARRAY: PN_DOUBLE_ARRAY, PN_UINT_ARRAY, PN_BYTE_ARRAY (uint8),
//   PN_VEC2_ARRAY and PN_VEC3_ARRAY, read with PN_AT; in GLSL the buffer references Doubles and
//   Bytes (declared here) and Uints, Vec2s, Vec3s (kernel_common.glsl).
// A double constant that is no float's value cannot be written in both languages (GLSL wants
// 0.3lf, and glslang pastes no suffix onto a number): such constants come from the host, in the
// records the kernels read.
#ifndef PENUMBRA_CORE_SHADER_COMPAT_MATH_H
#define PENUMBRA_CORE_SHADER_COMPAT_MATH_H

#include "penumbra/core/shader_compat.h"

#ifdef __cplusplus
#include <cmath>
#include <cstdint>

namespace penumbra::shader {
inline double pn_dmin(double a, double b) { return b < a ? b : a; }
inline double pn_dmax(double a, double b) { return a < b ? b : a; }
inline double pn_dfloor(double x) { return std::floor(x); }
inline double pn_exp_d(double x) { return std::exp(x); }
inline double pn_log_d(double x) { return std::log(x); }
inline float pn_expf(float x) { return std::exp(x); }
inline float pn_powf(float x, float y) { return std::pow(x, y); }
inline float pn_log2f(float x) { return std::log2(x); }
inline float pn_ceilf(float x) { return std::ceil(x); }
inline bool pn_disfinite(double x) { return std::isfinite(x); }
}  // namespace penumbra::shader

#define PN_DOUBLE_ARRAY const double*
#define PN_UINT_ARRAY const uint32_t*
#define PN_BYTE_ARRAY const uint8_t*
#define PN_VEC2_ARRAY const penumbra::Vec2f*
#define PN_VEC3_ARRAY const penumbra::Vec3f*
#else
layout(buffer_reference, scalar) buffer Doubles { double v[]; };
layout(buffer_reference, scalar) buffer Bytes { uint8_t v[]; };

double pn_dmin(double a, double b) { return b < a ? b : a; }
double pn_dmax(double a, double b) { return a < b ? b : a; }
double pn_dfloor(double x) { return floor(x); }
float pn_log2f(float x) { return log2(x); }
float pn_ceilf(float x) { return ceil(x); }
// From the bits, so that no driver's float controls decide it (Vulkan need not keep inf or NaN).
bool pn_disfinite(double x) { return (unpackDouble2x32(x).y & 0x7ff00000u) != 0x7ff00000u; }

// Cephes exp: x = n ln 2 + r (ln 2 in two parts, so n ln 2 is exact), |r| <= ln 2 / 2;
// e^r = 1 + 2 r P(r^2) / (Q(r^2) - r P(r^2)); then 2^n. For |x| < 700.
double pn_exp_d(double x) {
  double n = floor(x * 1.4426950408889634073599lf + 0.5lf);
  precise double r = x - n * 6.93145751953125e-1lf;
  r = r - n * 1.42860682030941723212e-6lf;
  double xx = r * r;
  double px = r * ((1.26177193074810590878e-4lf * xx + 3.02994407707441961300e-2lf) * xx + 9.99999999999999999910e-1lf);
  double qx = ((3.00198505138664455042e-6lf * xx + 2.52448340349684104192e-3lf) * xx + 2.27265548208155028766e-1lf) * xx +
              2.00000000000000000009e0lf;
  double y = 1.0lf + 2.0lf * (px / (qx - px));
  return ldexp(y, int(n));
}

// Cephes log: x = m 2^e with m in [sqrt(1/2), sqrt(2)); log(1 + f) = f - f^2/2 + f^3 P(f) / Q(f);
// e ln 2 added in two parts. For x > 0.
double pn_log_d(double x) {
  int e;
  double m = frexp(x, e);
  if (m < 0.70710678118654752440lf) {
    e -= 1;
    m = 2.0lf * m - 1.0lf;
  } else {
    m = m - 1.0lf;
  }
  double z = m * m;
  double p = ((((1.01875663804580931796e-4lf * m + 4.97494994976747001425e-1lf) * m + 4.70579119878881725854e0lf) * m +
               1.44989225341610930846e1lf) * m + 1.79368678507819816313e1lf) * m + 7.70838733755885391666e0lf;
  double q = ((((m + 1.12873587189167450590e1lf) * m + 4.52279145837532221105e1lf) * m + 8.29875266912776603211e1lf) * m +
              7.11544750618563894466e1lf) * m + 2.31251620126765340583e1lf;
  double de = double(e);
  precise double y = m * (z * p / q);
  y = y - de * 2.121944400546905827679e-4lf;
  y = y - 0.5lf * z;
  precise double r = m + y;
  r = r + de * 0.693359375lf;
  return r;
}

// expf and powf (x >= 0) through the double ones, rounded once: libm's expf and powf are within an
// ulp of the true value, and so is this, so both devices' floats agree but for the rare value
// near a rounding tie (the GPU's built-ins may be several ulps off). Beyond float's range: 0 or
// +inf, as libm's.
float pn_expf(float x) {
  if (x < -104.0f) return 0.0f;
  if (x > 89.0f) return uintBitsToFloat(0x7f800000u);
  return float(pn_exp_d(double(x)));
}
float pn_powf(float x, float y) {
  if (y == 0.0f) return 1.0f;
  if (x == 0.0f) return y > 0.0f ? 0.0f : uintBitsToFloat(0x7f800000u);
  double e = double(y) * pn_log_d(double(x));
  if (e < -104.0lf) return 0.0f;
  if (e > 89.0lf) return uintBitsToFloat(0x7f800000u);
  return float(pn_exp_d(e));
}

#define PN_DOUBLE_ARRAY Doubles
#define PN_UINT_ARRAY Uints
#define PN_BYTE_ARRAY Bytes
#define PN_VEC2_ARRAY Vec2s
#define PN_VEC3_ARRAY Vec3s
#endif

#endif  // PENUMBRA_CORE_SHADER_COMPAT_MATH_H
