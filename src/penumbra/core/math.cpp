#include "penumbra/core/math.h"

#include "penumbra/core/error.h"

namespace penumbra {

Mat4 Mat4::translate(Vec3f t) {
  Mat4 r;
  r.m[0][3] = t.x; r.m[1][3] = t.y; r.m[2][3] = t.z;
  return r;
}

Mat4 Mat4::scale(Vec3f s) {
  Mat4 r;
  r.m[0][0] = s.x; r.m[1][1] = s.y; r.m[2][2] = s.z;
  return r;
}

Mat4 Mat4::rotate_x(float deg) {
  float c = std::cos(radians(deg)), s = std::sin(radians(deg));
  Mat4 r;
  r.m[1][1] = c; r.m[1][2] = -s; r.m[2][1] = s; r.m[2][2] = c;
  return r;
}

Mat4 Mat4::rotate_y(float deg) {
  float c = std::cos(radians(deg)), s = std::sin(radians(deg));
  Mat4 r;
  r.m[0][0] = c; r.m[0][2] = s; r.m[2][0] = -s; r.m[2][2] = c;
  return r;
}

Mat4 Mat4::rotate_z(float deg) {
  float c = std::cos(radians(deg)), s = std::sin(radians(deg));
  Mat4 r;
  r.m[0][0] = c; r.m[0][1] = -s; r.m[1][0] = s; r.m[1][1] = c;
  return r;
}

Mat4 Mat4::look_at(Vec3f eye, Vec3f target, Vec3f up) {
  Vec3f f = normalize(target - eye);
  Vec3f s = cross(f, up);
  if (length_squared(s) < 1e-12f) {  // up parallel to the view direction: pick any
    Vec3f t, b;
    coordinate_system(f, &t, &b);
    s = t;
  }
  s = normalize(s);
  Vec3f u = cross(s, f);
  Mat4 r;
  r.m[0][0] = s.x; r.m[0][1] = s.y; r.m[0][2] = s.z; r.m[0][3] = -dot(s, eye);
  r.m[1][0] = u.x; r.m[1][1] = u.y; r.m[1][2] = u.z; r.m[1][3] = -dot(u, eye);
  r.m[2][0] = -f.x; r.m[2][1] = -f.y; r.m[2][2] = -f.z; r.m[2][3] = dot(f, eye);
  return r;
}

Mat4 Mat4::frustum(float l, float r, float b, float t, float n, float f) {
  Mat4 p;
  p.m[0][0] = 2 * n / (r - l); p.m[0][2] = (r + l) / (r - l);
  p.m[1][1] = 2 * n / (t - b); p.m[1][2] = (t + b) / (t - b);
  p.m[2][2] = -(f + n) / (f - n); p.m[2][3] = -2 * f * n / (f - n);
  p.m[3][2] = -1; p.m[3][3] = 0;
  return p;
}

Mat4 Mat4::perspective(float fov_y_deg, float aspect, float n, float f) {
  float t = n * std::tan(radians(fov_y_deg) * 0.5f);
  return frustum(-t * aspect, t * aspect, -t, t, n, f);
}

Mat4 Mat4::orthographic(float l, float r, float b, float t, float n, float f) {
  Mat4 p;
  p.m[0][0] = 2 / (r - l); p.m[0][3] = -(r + l) / (r - l);
  p.m[1][1] = 2 / (t - b); p.m[1][3] = -(t + b) / (t - b);
  p.m[2][2] = -2 / (f - n); p.m[2][3] = -(f + n) / (f - n);
  return p;
}

Mat4 Mat4::operator*(const Mat4& o) const {
  Mat4 r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      float s = 0;
      for (int k = 0; k < 4; ++k) s += m[i][k] * o.m[k][j];
      r.m[i][j] = s;
    }
  return r;
}

void Mat4::transform_homogeneous(Vec3f p, float out[4]) const {
  for (int i = 0; i < 4; ++i) out[i] = m[i][0] * p.x + m[i][1] * p.y + m[i][2] * p.z + m[i][3];
}

Vec3f Mat4::transform_point(Vec3f p) const {
  float h[4];
  transform_homogeneous(p, h);
  if (h[3] != 1.0f && h[3] != 0.0f) return {h[0] / h[3], h[1] / h[3], h[2] / h[3]};
  return {h[0], h[1], h[2]};
}

Vec3f Mat4::transform_vector(Vec3f v) const {
  return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
          m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
          m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
}

Mat4 Mat4::transposed() const {
  Mat4 r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r.m[i][j] = m[j][i];
  return r;
}

// Gauss-Jordan elimination with partial pivoting, in double for accuracy.
Mat4 Mat4::inverse() const {
  double a[4][8];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      a[i][j] = m[i][j];
      a[i][j + 4] = (i == j) ? 1.0 : 0.0;
    }
  for (int c = 0; c < 4; ++c) {
    int piv = c;
    for (int r = c + 1; r < 4; ++r)
      if (std::abs(a[r][c]) > std::abs(a[piv][c])) piv = r;
    if (std::abs(a[piv][c]) < 1e-20) throw Error("Mat4::inverse: singular matrix");
    if (piv != c)
      for (int j = 0; j < 8; ++j) std::swap(a[c][j], a[piv][j]);
    double inv = 1.0 / a[c][c];
    for (int j = 0; j < 8; ++j) a[c][j] *= inv;
    for (int r = 0; r < 4; ++r) {
      if (r == c) continue;
      double f = a[r][c];
      if (f == 0) continue;
      for (int j = 0; j < 8; ++j) a[r][j] -= f * a[c][j];
    }
  }
  Mat4 r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r.m[i][j] = static_cast<float>(a[i][j + 4]);
  return r;
}

}  // namespace penumbra
