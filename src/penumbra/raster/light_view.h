// A view from a light: where it sits, where it looks, its projection and the resolution
// of the images rendered from it. Every raster mode, and every method that reads those
// images back (shadow-map lookups, epipolar walks, warps), goes through this one type so
// they agree on texel centres and on what "depth" means.
//
// Conventions (docs/raster.md):
// - View space is right-handed: x right, y up, the light looks along -z (Mat4::look_at).
//   The *linear depth* z of a point is its distance from the eye plane along the view
//   axis, positive in front: z = dot(p - eye, forward). This is the "camera space z" of
//   xie2007 §6.1, in world units; thresholds and biases are given in it.
// - Texel space: x in [0, width) to the right, y in [0, height) *downward* (row 0 is the top
//   of the light's image, as in image files). Texel (i, j) is the square [i, i+1) x [j, j+1)
//   and is sampled at its centre (i + 0.5, j + 0.5).
// - Window depth d in [0, 1] (0 at near, 1 at far) is what a hardware depth buffer stores:
//   monotonic in z and affine in texel space across a planar triangle, so it can be
//   interpolated linearly along a screen-space segment (xie2007 §4.3, §6.1). For an
//   orthographic view d is affine in z as well.
#pragma once

#include <array>

#include "penumbra/core/math.h"
#include "penumbra/raster/raster_shared.h"

namespace penumbra {

enum class ProjectionKind { Perspective, Orthographic };

// The part of a box at linear depth >= min_near of a view frame (eye; right, up, forward) is
// a convex polytope; its vertices are the box corners beyond the plane z = min_near and the
// points where box edges cross that plane (at most 8 + 12). Every extreme of z, x/z and y/z
// over the part is reached at one of them, so fitting a frustum or projecting the box's
// window needs these points only. Points are (x, y, z) view coordinates.
struct BoxPartBeyondNear {
  std::array<Vec3f, 20> points;
  int count = 0;
};
BoxPartBeyondNear box_part_beyond_near(const Bounds3f& bounds, Vec3f eye, Vec3f right, Vec3f up,
                                       Vec3f forward, float min_near);

class LightView {
 public:
  // A ray through a texel-space point: origin + z * dir lies at linear depth z (dir is not
  // unit length for a perspective view; normalise it for a unit-speed ray).
  struct TexelRay {
    Vec3f origin;
    Vec3f dir;
    Vec3f at(float z) const { return origin + dir * z; }
  };

  LightView() = default;

  // Symmetric perspective view from `eye` along `dir` with square texels; fov_y_deg is the
  // full vertical field of view. `up` only fixes the roll (any vector not parallel to dir).
  static LightView perspective(Vec3f eye, Vec3f dir, Vec3f up, float fov_y_deg, int width,
                               int height, float near, float far);
  // Off-centre perspective view (glFrustum): the window [l, r] x [b, t] lies on the plane
  // at linear depth `near`, in view-space units.
  static LightView frustum(Vec3f eye, Vec3f dir, Vec3f up, float l, float r, float b, float t,
                           float near, float far, int width, int height);
  // The tightest off-centre frustum from `eye` along `dir` that contains the part of
  // `bounds` at linear depth >= min_near; near and far are fitted to that part too
  // (near >= min_near). Throws if no part of `bounds` lies beyond min_near.
  static LightView frustum_fitted(Vec3f eye, Vec3f dir, Vec3f up, const Bounds3f& bounds,
                                  int width, int height, float min_near);
  // Orthographic view along `dir`: the window [l, r] x [b, t] is in view-space units around
  // `eye`, and linear depth is measured from the plane through `eye`.
  static LightView orthographic(Vec3f eye, Vec3f dir, Vec3f up, float l, float r, float b,
                                float t, float near, float far, int width, int height);
  // The tightest orthographic view along `dir` containing `bounds` (eye placed in front).
  static LightView orthographic_fitted(Vec3f dir, Vec3f up, const Bounds3f& bounds, int width,
                                       int height);

  ProjectionKind kind() const { return kind_; }
  bool is_perspective() const { return kind_ == ProjectionKind::Perspective; }
  int width() const { return width_; }
  int height() const { return height_; }
  float near() const { return near_; }
  float far() const { return far_; }
  Vec3f eye() const { return eye_; }
  // The view axes in world space: right, up and forward (= -z of view space).
  Vec3f right() const { return right_; }
  Vec3f up() const { return up_; }
  Vec3f forward() const { return forward_; }
  // The image-plane window [l, r] x [b, t] (at linear depth `near` for a perspective view).
  float window_left() const { return l_; }
  float window_right() const { return r_; }
  float window_bottom() const { return b_; }
  float window_top() const { return t_; }

  // OpenGL-convention matrices for code that wants them (clip z in [-1, 1]).
  const Mat4& view() const { return view_; }
  const Mat4& projection() const { return projection_; }
  Mat4 view_projection() const { return projection_ * view_; }
  // A point's offset from the eye, p - eye(), -> homogeneous texel coordinates (X, Y, z, w):
  // texel = (X / w, Y / w), z is the linear depth, w = z for a perspective view and 1 for an
  // orthographic one. Everything here is affine in the point, so clipping can interpolate it
  // (the rasterizer does). It takes p - eye, not p: far from the world's origin (a georeferenced
  // model 2 x 10^4 units out) a world-space matrix would subtract two coordinates of that size
  // after rounding each, and lose depths and texel positions to its ulp (0.002); p - eye is exact
  // to the ulp of p, and what follows is at the view's own scale.
  const Mat4& texel_projection() const { return texel_projection_; }
  // texel_projection applied to p (p - eye first).
  void texel_homogeneous(Vec3f p, float h[4]) const { texel_projection_.transform_homogeneous(p - eye_, h); }

  float linear_depth(Vec3f world) const { return dot(world - eye_, forward_); }
  // Window depth of a linear depth and back (see the conventions above).
  float window_depth(float z) const {
    return is_perspective() ? far_ * (z - near_) / ((far_ - near_) * z) : (z - near_) / (far_ - near_);
  }
  float linear_depth_from_window(float d) const {
    return is_perspective() ? far_ * near_ / (far_ - d * (far_ - near_)) : near_ + d * (far_ - near_);
  }

  // (x, y) in texel space and the linear depth z of a world point. For a perspective view
  // x and y are meaningless when z <= 0 (behind the eye).
  Vec3f to_texel(Vec3f world) const;
  // The world point at linear depth z on the ray through texel-space point (x, y).
  Vec3f texel_to_world(Vec2f texel, float z) const { return texel_ray(texel).at(z); }
  TexelRay texel_ray(Vec2f texel) const;
  // World-space width of one texel at linear depth z (constant for orthographic views):
  // the scale of a depth-map sample, for biases and thresholds.
  float texel_world_size(float z) const;
  // The view as kernels and the shared functions of raster_shared.h read it (RasterView).
  const shader::RasterView& shared() const { return shared_; }

 private:
  // frustum() and orthographic() after their own depth checks: checks the resolution and
  // the window, sets the fields, derives the matrices (finish()).
  static LightView make(ProjectionKind kind, Vec3f eye, Vec3f dir, Vec3f up, float l, float r,
                        float b, float t, float near, float far, int width, int height);
  void finish();

  ProjectionKind kind_ = ProjectionKind::Perspective;
  int width_ = 1, height_ = 1;
  float near_ = 0.1f, far_ = 1.0f;
  float l_ = -1, r_ = 1, b_ = -1, t_ = 1;
  Vec3f eye_, right_{1, 0, 0}, up_{0, 1, 0}, forward_{0, 0, -1};
  Mat4 view_, projection_, texel_projection_;
  shader::RasterView shared_{};
};

}  // namespace penumbra
