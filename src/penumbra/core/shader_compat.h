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
//   parameters as PN_OUT(T) and PN_INOUT(T); no overloading on the argument type alone;
// - the GLSL built-ins below only (C++ gets them here), no swizzles beyond .x .y .z;
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
inline float sin(float x) { return std::sin(x); }
inline float cos(float x) { return std::cos(x); }
inline float acos(float x) { return std::acos(x); }
inline float atan(float y, float x) { return std::atan2(y, x); }
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
#define PN_OUT(T) T&
#define PN_INOUT(T) T&
#define PN_CONST inline constexpr
#define PN_INLINE inline
#define PN_PRECISE
#else
#define PN_FLOAT_ARRAY Floats
#define PN_AT(array, i) array.v[i]
double atan2_double(double y, double x) { return double(atan(float(y), float(x))); }
#define PN_SHARED_BEGIN
#define PN_SHARED_END
#define PN_OUT(T) out T
#define PN_INOUT(T) inout T
#define PN_CONST const
#define PN_INLINE
#define PN_PRECISE precise
#endif

#endif  // PENUMBRA_CORE_SHADER_COMPAT_H
