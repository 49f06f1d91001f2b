// The common subset of C++ and GLSL (DESIGN.md, "one source of truth across the two
// languages"): a header written in it is compiled as C++ into penumbra and #included by the GPU
// kernels (glslc -I src), so the random generator, the light-sample warps and the GPU's buffer
// layouts exist once. The *_shared.h headers are such headers; tests run each function on both
// sides and compare the bits.
//
// Rules for a shared header:
// - include this file first, wrap the body in PN_SHARED_BEGIN / PN_SHARED_END, guard with
//   #ifndef (GLSL has no #pragma once);
// - types: float, int, uint, bool, uint64_t, vec2, vec3, structs of them; float literals with an
//   f suffix (1.0f: a bare 1.0 is a double in C++), unsigned ones with u, 64-bit with UL;
// - conversions written out (float(i), uint(x)); no references or pointers: out and inout
//   parameters as PN_OUT(T) and PN_INOUT(T); no overloading on the argument type alone;
// - the GLSL built-ins below only (C++ gets them here), no swizzles beyond .x .y .z.
#ifndef PENUMBRA_CORE_SHADER_COMPAT_H
#define PENUMBRA_CORE_SHADER_COMPAT_H

#ifdef __cplusplus
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
}  // namespace penumbra::shader

#define PN_SHARED_BEGIN namespace penumbra::shader {
#define PN_SHARED_END }
#define PN_OUT(T) T&
#define PN_INOUT(T) T&
#define PN_CONST inline constexpr
#define PN_INLINE inline
#else
#define PN_SHARED_BEGIN
#define PN_SHARED_END
#define PN_OUT(T) out T
#define PN_INOUT(T) inout T
#define PN_CONST const
#define PN_INLINE
#endif

#endif  // PENUMBRA_CORE_SHADER_COMPAT_H
