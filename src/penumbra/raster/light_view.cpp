#include "penumbra/raster/light_view.h"

#include <vector>

#include "penumbra/core/error.h"

namespace penumbra {
namespace {

// Right/up/forward for a view along dir with roll fixed by up_hint (as Mat4::look_at).
void view_axes(Vec3f dir, Vec3f up_hint, Vec3f* right, Vec3f* up, Vec3f* forward) {
  if (!(length_squared(dir) > 0) || !is_finite(dir)) throw Error("LightView: direction must be a non-zero vector");
  *forward = normalize(dir);
  Vec3f s = cross(*forward, up_hint);
  if (!(length_squared(s) > 1e-12f)) {  // up parallel to the view direction: any roll will do
    Vec3f t, b;
    coordinate_system(*forward, &t, &b);
    s = t;
  }
  *right = normalize(s);
  *up = cross(*right, *forward);
}

void check_resolution(int width, int height) {
  // The rasterizer snaps texel coordinates to 1/256 texel in 64-bit edge functions with a
  // guard band; 16384 keeps every product far from overflow (rasterizer.cpp).
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw Error("LightView: resolution {}x{} must be between 1 and 16384 per side", width, height);
}

}  // namespace

LightView LightView::frustum(Vec3f eye, Vec3f dir, Vec3f up, float l, float r, float b, float t,
                             float near, float far, int width, int height) {
  if (!(near > 0) || !(far > near)) throw Error("LightView: need 0 < near < far (got {}, {})", near, far);
  return make(ProjectionKind::Perspective, eye, dir, up, l, r, b, t, near, far, width, height);
}

LightView LightView::perspective(Vec3f eye, Vec3f dir, Vec3f up, float fov_y_deg, int width,
                                 int height, float near, float far) {
  if (!(fov_y_deg > 0) || !(fov_y_deg < 180)) throw Error("LightView: fov {} must be in (0, 180) degrees", fov_y_deg);
  check_resolution(width, height);
  float t = near * std::tan(radians(fov_y_deg) * 0.5f);
  float r = t * static_cast<float>(width) / static_cast<float>(height);
  return frustum(eye, dir, up, -r, r, -t, t, near, far, width, height);
}

BoxPartBeyondNear box_part_beyond_near(const Bounds3f& bounds, Vec3f eye, Vec3f right, Vec3f up,
                                       Vec3f forward, float min_near) {
  BoxPartBeyondNear part;
  if (bounds.empty()) return part;
  Vec3f corner[8];
  for (int i = 0; i < 8; ++i) {
    Vec3f d = bounds.corner(i) - eye;
    corner[i] = {dot(d, right), dot(d, up), dot(d, forward)};
  }
  for (int i = 0; i < 8; ++i) {
    if (corner[i].z >= min_near) part.points[part.count++] = corner[i];
    // Each of the 12 edges once, from its corner with the lower index.
    for (int axis = 0; axis < 3; ++axis) {
      int j = i | (1 << axis);
      if (j == i) continue;
      float zi = corner[i].z - min_near, zj = corner[j].z - min_near;
      if ((zi < 0) != (zj < 0)) {
        float s = zi / (zi - zj);
        Vec3f p = corner[i] + (corner[j] - corner[i]) * s;
        p.z = min_near;
        part.points[part.count++] = p;
      }
    }
  }
  return part;
}

LightView LightView::frustum_fitted(Vec3f eye, Vec3f dir, Vec3f up, const Bounds3f& bounds,
                                    int width, int height, float min_near) {
  if (bounds.empty()) throw Error("LightView::frustum_fitted: empty bounds");
  if (!(min_near > 0)) throw Error("LightView::frustum_fitted: min_near must be positive (got {})", min_near);
  Vec3f right, upv, fwd;
  view_axes(dir, up, &right, &upv, &fwd);
  const BoxPartBeyondNear part = box_part_beyond_near(bounds, eye, right, upv, fwd, min_near);
  if (part.count == 0) throw Error("LightView::frustum_fitted: the bounds lie entirely within min_near of the eye or behind it");
  float near = kInfinity, far = 0, sx0 = kInfinity, sx1 = -kInfinity, sy0 = kInfinity, sy1 = -kInfinity;
  for (int i = 0; i < part.count; ++i) {
    const Vec3f p = part.points[i];
    near = std::min(near, p.z);
    far = std::max(far, p.z);
    sx0 = std::min(sx0, p.x / p.z); sx1 = std::max(sx1, p.x / p.z);
    sy0 = std::min(sy0, p.y / p.z); sy1 = std::max(sy1, p.y / p.z);
  }
  // A little slack so geometry lying exactly on the fitted boundary survives float error.
  near = std::max(min_near, near * (1 - 1e-5f));
  far = std::max(far * (1 + 1e-5f), near * (1 + 1e-4f));
  float px = std::max(1e-6f, (sx1 - sx0) * 1e-5f), py = std::max(1e-6f, (sy1 - sy0) * 1e-5f);
  return frustum(eye, dir, up, (sx0 - px) * near, (sx1 + px) * near, (sy0 - py) * near,
                 (sy1 + py) * near, near, far, width, height);
}

LightView LightView::orthographic(Vec3f eye, Vec3f dir, Vec3f up, float l, float r, float b,
                                  float t, float near, float far, int width, int height) {
  if (!(far > near)) throw Error("LightView: need near < far (got {}, {})", near, far);
  return make(ProjectionKind::Orthographic, eye, dir, up, l, r, b, t, near, far, width, height);
}

LightView LightView::orthographic_fitted(Vec3f dir, Vec3f up, const Bounds3f& bounds, int width,
                                         int height) {
  if (bounds.empty()) throw Error("LightView::orthographic_fitted: empty bounds");
  Vec3f right, upv, fwd;
  view_axes(dir, up, &right, &upv, &fwd);
  float extent = std::max(length(bounds.diagonal()), 1e-6f);
  Vec3f eye = bounds.center() - fwd * extent;  // every corner lies at z in [extent/2, 3 extent/2]
  float x0 = kInfinity, x1 = -kInfinity, y0 = kInfinity, y1 = -kInfinity, z0 = kInfinity, z1 = -kInfinity;
  for (int i = 0; i < 8; ++i) {
    Vec3f d = bounds.corner(i) - eye;
    x0 = std::min(x0, dot(d, right)); x1 = std::max(x1, dot(d, right));
    y0 = std::min(y0, dot(d, upv)); y1 = std::max(y1, dot(d, upv));
    z0 = std::min(z0, dot(d, fwd)); z1 = std::max(z1, dot(d, fwd));
  }
  float pad = extent * 1e-5f;
  return orthographic(eye, dir, up, x0 - pad, x1 + pad, y0 - pad, y1 + pad, z0 - pad, z1 + pad,
                      width, height);
}

LightView LightView::make(ProjectionKind kind, Vec3f eye, Vec3f dir, Vec3f up, float l, float r,
                          float b, float t, float near, float far, int width, int height) {
  check_resolution(width, height);
  if (!(r > l) || !(t > b)) throw Error("LightView: empty window [{}, {}] x [{}, {}]", l, r, b, t);
  LightView v;
  v.kind_ = kind;
  v.width_ = width;
  v.height_ = height;
  v.near_ = near;
  v.far_ = far;
  v.l_ = l; v.r_ = r; v.b_ = b; v.t_ = t;
  v.eye_ = eye;
  view_axes(dir, up, &v.right_, &v.up_, &v.forward_);
  v.finish();
  return v;
}

void LightView::finish() {
  view_ = Mat4::look_at(eye_, eye_ + forward_, up_);
  float W = static_cast<float>(width_), H = static_cast<float>(height_);
  Mat4& m = texel_projection_;
  auto set_row = [&](int row, Vec3f v, float offset) {
    m.m[row][0] = v.x; m.m[row][1] = v.y; m.m[row][2] = v.z;
    m.m[row][3] = offset;  // of p - eye (light_view.h texel_projection)
  };
  if (kind_ == ProjectionKind::Perspective) {
    projection_ = Mat4::frustum(l_, r_, b_, t_, near_, far_);
    // x_texel = (x_view * near / z - l) * W / (r - l), multiplied through by w = z.
    set_row(0, right_ * (near_ * W / (r_ - l_)) - forward_ * (l_ * W / (r_ - l_)), 0);
    // y_texel = (t - y_view * near / z) * H / (t - b): rows grow downward.
    set_row(1, forward_ * (t_ * H / (t_ - b_)) - up_ * (near_ * H / (t_ - b_)), 0);
    set_row(2, forward_, 0);
    set_row(3, forward_, 0);
  } else {
    projection_ = Mat4::orthographic(l_, r_, b_, t_, near_, far_);
    set_row(0, right_ * (W / (r_ - l_)), -l_ * W / (r_ - l_));
    set_row(1, up_ * (-H / (t_ - b_)), t_ * H / (t_ - b_));
    set_row(2, forward_, 0);
    m.m[3][0] = 0; m.m[3][1] = 0; m.m[3][2] = 0; m.m[3][3] = 1;
  }
  shader::RasterView& s = shared_;
  s = {};
  s.row0 = {m.m[0][0], m.m[0][1], m.m[0][2]};
  s.off0 = m.m[0][3];
  s.row1 = {m.m[1][0], m.m[1][1], m.m[1][2]};
  s.off1 = m.m[1][3];
  s.row2 = {m.m[2][0], m.m[2][1], m.m[2][2]};
  s.off2 = m.m[2][3];
  s.row3 = {m.m[3][0], m.m[3][1], m.m[3][2]};
  s.off3 = m.m[3][3];
  s.eye = eye_;
  s.near = near_;
  s.right = right_;
  s.far = far_;
  s.up = up_;
  s.width = width_;
  s.forward = forward_;
  s.height = height_;
  s.l = l_;
  s.r = r_;
  s.b = b_;
  s.t = t_;
  s.perspective = kind_ == ProjectionKind::Perspective ? 1u : 0u;
}

Vec3f LightView::to_texel(Vec3f world) const {
  float h[4];
  texel_homogeneous(world, h);
  return {h[0] / h[3], h[1] / h[3], h[2]};
}

LightView::TexelRay LightView::texel_ray(Vec2f texel) const {
  TexelRay ray;
  shader::raster_texel_ray(shared_, texel.x, texel.y, ray.origin, ray.dir);
  return ray;
}

float LightView::texel_world_size(float z) const {
  float size = (r_ - l_) / static_cast<float>(width_);
  return kind_ == ProjectionKind::Perspective ? size * z / near_ : size;
}

}  // namespace penumbra
