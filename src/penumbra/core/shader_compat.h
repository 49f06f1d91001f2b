// The common subset of C++ and GLSL (DESIGN.md, "one source of truth across the two
// languages"): a header written in it is compiled as C++ into penumbra and #included by the GPU
// kernels (glslc -I src), so the random generator, the light-sample warps and the GPU's buffer
// layouts exist once. The *_shared.h headers are such headers; tests run each function on both
// sides and compare the bits.
//
// Rules for a shared header:
// - include this file first, wrap the body in PN_SHARED_BEGIN / PN_SHARED_END, guard with
//   #ifndef (GLSL has no #pragma once);
// - types: float, int, uint, bool, int64_t, uint64_t, vec2, vec3, double, dvec3, structs of them; float
//   literals with an f suffix (1.0f: a bare 1.0 is a double in C++ and a float in GLSL), double
//   constants as double(0.5f), unsigned literals with u, 64-bit with UL;
// - conversions written out (float(i), uint(x)); no references or pointers: out and inout
//   parameters as PN_OUT(T) and PN_INOUT(T), a large read-only one as PN_IN(T) (a const reference
//   in C++, so a 160-byte view is not copied per call); no overloading on the argument type alone;
// - the GLSL built-ins below only (C++ gets them here), no swizzles beyond .x .y .z;
// - trigonometry as pn_sin, pn_cos, pn_acos and atan2_double: Vulkan lets a GPU's built-in sin and
//   cos be off by 2^-11 (absolute) and atan by 4096 ulp, so the GPU side gets its own (Cephes'
//   polynomials, within a few ulp of libm), the CPU side libm's;
// - arrays as PN_FLOAT_ARRAY parameters read with PN_AT (in GLSL after kernel_common.glsl);
// - PN_PRECISE on a variable whose value must be the CPU's float for float: GLSL's `precise`
//   forbids the driver to fuse or reorder what computes it (C++ does neither without -ffast-math
//   and without FMA in the target, penumbra's build).
#ifndef PENUMBRA_CORE_SHADER_COMPAT_H
#define PENUMBRA_CORE_SHADER_COMPAT_H

#ifdef __cplusplus
#include <bit>
#include <cmath>
#include <cstdint>

#include "penumbra/core/math.h"

namespace penumbra::shader {
using uint = uint32_t;
using vec2 = Vec2f;
using vec3 = Vec3f;
// GLSL built-ins the shared headers use. dot, cross, length and normalize are penumbra's own
// (core/math.h), found by argument-dependent lookup.
inline float min(float a, float b) { return a < b ? a : b; }
inline float max(float a, float b) { return a > b ? a : b; }
inline int min(int a, int b) { return a < b ? a : b; }
inline int max(int a, int b) { return a > b ? a : b; }
inline uint min(uint a, uint b) { return a < b ? a : b; }
inline uint max(uint a, uint b) { return a > b ? a : b; }
inline int64_t min(int64_t a, int64_t b) { return a < b ? a : b; }
inline int64_t max(int64_t a, int64_t b) { return a > b ? a : b; }
inline float clamp(float x, float lo, float hi) { return min(max(x, lo), hi); }
inline double clamp(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }
inline float abs(float x) { return std::fabs(x); }
inline double abs(double x) { return std::fabs(x); }
inline float sqrt(float x) { return std::sqrt(x); }
inline double sqrt(double x) { return std::sqrt(x); }
// Trigonometry in shared code goes through pn_sin, pn_cos, pn_acos (see the GLSL side below).
inline float pn_sin(float x) { return std::sin(x); }
inline float pn_cos(float x) { return std::cos(x); }
inline float pn_acos(float x) { return std::acos(x); }
inline float floor(float x) { return std::floor(x); }
inline float sign(float x) { return x > 0 ? 1.0f : (x < 0 ? -1.0f : 0.0f); }
inline bool isinf(float x) { return std::isinf(x); }
inline bool isnan(float x) { return std::isnan(x); }
inline uint floatBitsToUint(float x) { return std::bit_cast<uint>(x); }
inline float uintBitsToFloat(uint x) { return std::bit_cast<float>(x); }
// GLSL's dvec3, for the sums that need double precision (Lambert's polygon formula).
struct dvec3 {
  double x = 0, y = 0, z = 0;
  dvec3() = default;
  dvec3(double x_, double y_, double z_) : x(x_), y(y_), z(z_) {}
  explicit dvec3(Vec3f v) : x(v.x), y(v.y), z(v.z) {}
  explicit dvec3(double s) : x(s), y(s), z(s) {}
  dvec3 operator+(dvec3 o) const { return {x + o.x, y + o.y, z + o.z}; }
  dvec3 operator-(dvec3 o) const { return {x - o.x, y - o.y, z - o.z}; }
  dvec3 operator*(double s) const { return {x * s, y * s, z * s}; }
};
inline double dot(dvec3 a, dvec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline dvec3 cross(dvec3 a, dvec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
// atan2 in double where the device has it (the CPU); GLSL has trigonometry in float only.
inline double atan2_double(double y, double x) { return std::atan2(y, x); }
}  // namespace penumbra::shader

// Read-only float arrays: a pointer in C++, a buffer reference (kernel_common.glsl's Floats)
// in GLSL; element i is PN_AT(array, i).
#define PN_FLOAT_ARRAY const float*
#define PN_AT(array, i) array[i]

#define PN_SHARED_BEGIN namespace penumbra::shader {
#define PN_SHARED_END }
#define PN_IN(T) const T&
#define PN_OUT(T) T&
#define PN_INOUT(T) T&
#define PN_CONST inline constexpr
#define PN_INLINE inline
#define PN_PRECISE
#else
#define PN_FLOAT_ARRAY Floats
#define PN_AT(array, i) array.v[i]

// Trigonometry to float precision on any Vulkan device (the built-ins may be off by 2^-11): Cephes'
// sinf/cosf (Cody-Waite reduction by pi/4 in three parts, minimax polynomials on [-pi/4, pi/4]),
// asinf/acosf and, in double for Lambert's formula, atan. Arguments here are angles of a few turns
// at most. `precise` keeps the compiler from fusing the reduction's products (its error terms).
float pn_sincos_reduced(float x, bool want_cos) {
  float sgn = 1.0f;
  if (!want_cos && x < 0.0f) {
    sgn = -1.0f;
    x = -x;
  }
  if (want_cos) x = abs(x);
  int j = int(x * 1.27323954473516f);  // 4 / pi
  precise float y = float(j);
  if ((j & 1) != 0) {
    j += 1;
    y += 1.0f;
  }
  j &= 7;
  if (j > 3) {
    sgn = -sgn;
    j -= 4;
  }
  if (want_cos && j > 1) sgn = -sgn;
  precise float r = ((x - y * 0.78515625f) - y * 2.4187564849853515625e-4f) - y * 3.77489497744594108e-8f;
  float z = r * r;
  float c = ((2.443315711809948e-5f * z - 1.388731625493765e-3f) * z + 4.166664568298827e-2f) * z * z - 0.5f * z + 1.0f;
  float s = ((-1.9515295891e-4f * z + 8.3321608736e-3f) * z - 1.6666654611e-1f) * z * r + r;
  bool use_cos = want_cos ? !(j == 1 || j == 2) : (j == 1 || j == 2);
  return sgn * (use_cos ? c : s);
}
float pn_sin(float x) { return pn_sincos_reduced(x, false); }
float pn_cos(float x) { return pn_sincos_reduced(x, true); }

// Cephes asinf on [0, 1] (|x| > 0.5 through asin(x) = pi/2 - 2 asin(sqrt((1 - x) / 2))).
float pn_asin_positive(float a) {
  bool big = a > 0.5f;
  float z = big ? 0.5f * (1.0f - a) : a * a;
  float x = big ? sqrt(z) : a;
  float p = ((((4.2163199048e-2f * z + 2.4181311049e-2f) * z + 4.5470025998e-2f) * z + 7.4953002686e-2f) * z +
             1.6666752422e-1f) * z * x + x;
  return big ? 1.5707963267948966f - 2.0f * p : p;
}
float pn_acos(float x) {
  // acos(x) = pi/2 - asin(x), with 2 asin(sqrt((1 - x) / 2)) near 1 where that would cancel.
  if (x > 0.5f) return 2.0f * pn_asin_positive(sqrt(0.5f * (1.0f - x)));
  if (x < -0.5f) return 3.14159265358979323846f - 2.0f * pn_asin_positive(sqrt(0.5f * (1.0f + x)));
  float a = pn_asin_positive(abs(x));
  return 1.5707963267948966f - (x < 0.0f ? -a : a);
}

// Cephes atan in double (rational approximation after reduction by tan(3 pi/8) and tan(pi/8)),
// and atan2 from it: what Lambert's formula needs for the small angles of far lights.
double pn_atan_double(double x) {
  double sgn = x < 0.0lf ? -1.0lf : 1.0lf;
  x = abs(x);
  double y = 0.0lf;
  double more = 0.0lf;
  if (x > 2.41421356237309504880lf) {
    y = 1.57079632679489661923lf;
    more = 6.123233995736765886130e-17lf;
    x = -1.0lf / x;
  } else if (x > 0.66lf) {
    y = 0.78539816339744830962lf;
    more = 0.5lf * 6.123233995736765886130e-17lf;
    x = (x - 1.0lf) / (x + 1.0lf);
  }
  double z = x * x;
  double p = (((-8.750608600031904122785e-1lf * z - 1.615753718733365076637e1lf) * z - 7.500855792314704667340e1lf) * z -
              1.228866684490136173410e2lf) * z - 6.485021904942025371773e1lf;
  double q = ((((z + 2.485846490142306297962e1lf) * z + 1.650270098316988542046e2lf) * z + 4.328810604912902668951e2lf) * z +
              4.853903996359136964868e2lf) * z + 1.945506571482613964425e2lf;
  z = z * p / q;
  z = x * z + x;
  return sgn * (y + (z + more));
}
double atan2_double(double y, double x) {
  // atan2's quadrants; y >= 0 in Lambert's formula (|a x b|), x any sign.
  if (x > 0.0lf) return pn_atan_double(y / x);
  if (x < 0.0lf) return (y >= 0.0lf ? 3.14159265358979323846lf : -3.14159265358979323846lf) + pn_atan_double(y / x);
  return y > 0.0lf ? 1.57079632679489661923lf : (y < 0.0lf ? -1.57079632679489661923lf : 0.0lf);
}
#define PN_SHARED_BEGIN
#define PN_SHARED_END
#define PN_IN(T) in T
#define PN_OUT(T) out T
#define PN_INOUT(T) inout T
#define PN_CONST const
#define PN_INLINE
#define PN_PRECISE precise
#endif

#endif  // PENUMBRA_CORE_SHADER_COMPAT_H
