// Small vector and frame types. Conventions, written once for all of penumbra:
// right-handed coordinates, y up; a Frame maps local (x, y, z) to world, with z the
// "normal" axis (a light's emitting direction, a light view's forward axis).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace penumbra {

inline constexpr float kPi = 3.14159265358979323846f;
inline constexpr float kInvPi = 0.31830988618379067154f;
inline constexpr float kInfinity = std::numeric_limits<float>::infinity();

inline float radians(float deg) { return deg * (kPi / 180.0f); }
inline float degrees(float rad) { return rad * (180.0f / kPi); }
inline float clamp01(float v) { return std::min(1.0f, std::max(0.0f, v)); }
template <typename T>
inline T lerp(float t, T a, T b) { return (1 - t) * a + t * b; }

struct Vec2f {
  float x = 0, y = 0;
  constexpr Vec2f() = default;
  constexpr Vec2f(float x_, float y_) : x(x_), y(y_) {}
  Vec2f operator+(Vec2f o) const { return {x + o.x, y + o.y}; }
  Vec2f operator-(Vec2f o) const { return {x - o.x, y - o.y}; }
  Vec2f operator*(float s) const { return {x * s, y * s}; }
  float operator[](int i) const { return i == 0 ? x : y; }
  float& operator[](int i) { return i == 0 ? x : y; }
};
inline Vec2f operator*(float s, Vec2f v) { return v * s; }
inline float dot(Vec2f a, Vec2f b) { return a.x * b.x + a.y * b.y; }
inline float cross(Vec2f a, Vec2f b) { return a.x * b.y - a.y * b.x; }

struct Vec3f {
  float x = 0, y = 0, z = 0;
  constexpr Vec3f() = default;
  constexpr Vec3f(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
  constexpr explicit Vec3f(float s) : x(s), y(s), z(s) {}
  Vec3f operator+(Vec3f o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3f operator-(Vec3f o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3f operator-() const { return {-x, -y, -z}; }
  Vec3f operator*(float s) const { return {x * s, y * s, z * s}; }
  Vec3f operator/(float s) const { float r = 1.0f / s; return {x * r, y * r, z * r}; }
  Vec3f operator*(Vec3f o) const { return {x * o.x, y * o.y, z * o.z}; }  // component-wise
  Vec3f& operator+=(Vec3f o) { x += o.x; y += o.y; z += o.z; return *this; }
  Vec3f& operator-=(Vec3f o) { x -= o.x; y -= o.y; z -= o.z; return *this; }
  Vec3f& operator*=(float s) { x *= s; y *= s; z *= s; return *this; }
  float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  float& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  bool operator==(const Vec3f&) const = default;
};
inline Vec3f operator*(float s, Vec3f v) { return v * s; }
inline float dot(Vec3f a, Vec3f b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3f cross(Vec3f a, Vec3f b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length_squared(Vec3f v) { return dot(v, v); }
inline float length(Vec3f v) { return std::sqrt(dot(v, v)); }
inline float distance(Vec3f a, Vec3f b) { return length(a - b); }
inline Vec3f normalize(Vec3f v) { return v / length(v); }
inline Vec3f vmin(Vec3f a, Vec3f b) { return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)}; }
inline Vec3f vmax(Vec3f a, Vec3f b) { return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)}; }
inline float max_component(Vec3f v) { return std::max(v.x, std::max(v.y, v.z)); }
inline float min_component(Vec3f v) { return std::min(v.x, std::min(v.y, v.z)); }
inline bool is_finite(Vec3f v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
inline float luminance(Vec3f c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

// Two unit vectors perpendicular to n and each other (Duff et al. 2017, "Building an
// orthonormal basis, revisited"): branch-free and continuous except at n.z = -1.
inline void coordinate_system(Vec3f n, Vec3f* t, Vec3f* b) {
  float sign = std::copysign(1.0f, n.z);
  float a = -1.0f / (sign + n.z);
  float c = n.x * n.y * a;
  *t = {1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x};
  *b = {c, sign + n.y * n.y * a, -n.y};
}

// An orthonormal frame: local (x, y, z) <-> world along (s, t, n).
struct Frame {
  Vec3f s{1, 0, 0}, t{0, 1, 0}, n{0, 0, 1};
  Frame() = default;
  Frame(Vec3f s_, Vec3f t_, Vec3f n_) : s(s_), t(t_), n(n_) {}
  static Frame from_z(Vec3f n) { Frame f; f.n = normalize(n); coordinate_system(f.n, &f.s, &f.t); return f; }
  // A frame with n as z and the projection of `x_hint` onto the plane as x.
  static Frame from_zx(Vec3f n, Vec3f x_hint) {
    Frame f;
    f.n = normalize(n);
    Vec3f x = x_hint - f.n * dot(x_hint, f.n);
    if (length_squared(x) < 1e-12f) return from_z(n);
    f.s = normalize(x);
    f.t = cross(f.n, f.s);
    return f;
  }
  Vec3f to_local(Vec3f v) const { return {dot(v, s), dot(v, t), dot(v, n)}; }
  Vec3f to_world(Vec3f v) const { return s * v.x + t * v.y + n * v.z; }
};

struct Bounds3f {
  Vec3f lo{kInfinity}, hi{-kInfinity};
  void extend(Vec3f p) { lo = vmin(lo, p); hi = vmax(hi, p); }
  void extend(const Bounds3f& b) { lo = vmin(lo, b.lo); hi = vmax(hi, b.hi); }
  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  Vec3f center() const { return (lo + hi) * 0.5f; }
  Vec3f diagonal() const { return hi - lo; }
  Vec3f corner(int i) const { return {(i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z}; }
};

// Row-major 4x4 matrix for affine object transforms and light/camera projections.
struct Mat4 {
  float m[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
  static Mat4 identity() { return {}; }
  static Mat4 translate(Vec3f t);
  static Mat4 scale(Vec3f s);
  static Mat4 rotate_x(float deg);
  static Mat4 rotate_y(float deg);
  static Mat4 rotate_z(float deg);
  // A right-handed view matrix: camera at eye looking along -z (OpenGL convention).
  static Mat4 look_at(Vec3f eye, Vec3f target, Vec3f up);
  // OpenGL-style perspective (clip z in [-1,1]); fov_y in degrees.
  static Mat4 perspective(float fov_y_deg, float aspect, float near, float far);
  // General frustum (off-centre), OpenGL glFrustum convention.
  static Mat4 frustum(float l, float r, float b, float t, float n, float f);
  static Mat4 orthographic(float l, float r, float b, float t, float n, float f);
  Mat4 operator*(const Mat4& o) const;
  Vec3f transform_point(Vec3f p) const;   // with the homogeneous divide
  Vec3f transform_vector(Vec3f v) const;  // upper 3x3 only
  // (x, y, z, w) of m * (p, 1), without the divide.
  void transform_homogeneous(Vec3f p, float out[4]) const;
  Mat4 inverse() const;
  Mat4 transposed() const;
};

}  // namespace penumbra
