// Area lights: rectangles, disks and spheres of uniform radiance. Visibility V is the
// fraction of the light's area a point sees (agrawala2000 eq. 2); irradiance E is eq. 1.
#pragma once

#include <string>
#include <vector>

#include "penumbra/core/math.h"

namespace penumbra {

enum class LightShape { Rect, Disk, Sphere };
const char* to_string(LightShape s);

struct AreaLight {
  LightShape shape = LightShape::Rect;
  Vec3f center{0, 0, 0};
  // frame.n is the emitting normal (rect, disk; one-sided), frame.s the rect's `u` axis.
  // For a sphere, frame.n points from the light toward the scene (set by the loader),
  // which is the axis of the disk that light-space methods sample.
  Frame frame;
  Vec2f size{1, 1};     // rect: full width (along s) and height (along t)
  float radius = 0.5f;  // disk, sphere
  Vec3f radiance{1, 1, 1};

  float area() const;  // rect and disk: the emitting area; sphere: its cross-section disk
  // Diameter of the light: rect, the diagonal; disk and sphere, 2r (parker1998's D).
  float diameter() const;
  // Largest distance from the centre to a point of the light (the "light radius" of
  // xie2007 eq. 4 and sintorn2008).
  float extent_radius() const;

  // Map u in [0,1)^2 uniformly onto the light's area: the rect, the disk, or for a sphere
  // the disk through its centre perpendicular to frame.n (what a light-space method sees).
  Vec3f sample_area(Vec2f u) const;
  // For a sphere, the disk perpendicular to the direction toward `p` (the silhouette seen
  // from p); identical to sample_area for rect and disk.
  Vec3f sample_area_toward(Vec2f u, Vec3f p) const;

  // Sample a direction from p toward the light, uniform in solid angle where possible
  // (spherical rectangles, Urena et al. 2013, for rects; cones for spheres; area
  // sampling for disks converted to solid angle). Returns false if p sees no part of
  // the emitting side. *dir is unit, *dist the distance to the light point, *pdf the
  // solid-angle density, *area_weight = (area pdf)/(solid-angle pdf) for self-normalised
  // estimates of area-fraction visibility.
  struct DirectionSample {
    Vec3f dir;
    float dist = 0;
    float pdf = 0;          // solid angle
    float area_weight = 0;  // p_A / p_omega, both as solid-angle densities
  };
  // (One-off; a loop over many samples at one point should use LightPointSampler.)
  bool sample_direction(Vec3f p, Vec2f u, DirectionSample* out) const;

  // Unshadowed irradiance at p with normal n (closed form): Lambert's polygon formula for
  // rects (clipped to n's hemisphere), disks as a 256-gon (error < 1e-4 relative), and
  // pi * L * sin^2(alpha) * cos(theta) for spheres entirely above the horizon (numeric
  // quadrature across the horizon). Per colour channel: radiance times the scalar.
  float unshadowed_irradiance_scalar(Vec3f p, Vec3f n) const;
  Vec3f unshadowed_irradiance(Vec3f p, Vec3f n) const { return radiance * unshadowed_irradiance_scalar(p, n); }

  // The light's outline as a convex polygon in world space (rect: 4 corners in
  // counter-clockwise order around frame.n; disk: `segments`-gon circumscribing the disk;
  // sphere: circumscribed polygon of the disk facing frame.n).
  std::vector<Vec3f> outline(int segments = 16) const;
  // Whether the emitting side faces p (always true for spheres).
  bool faces(Vec3f p) const;
};

// Direction sampling toward a light from one point p: the per-point set-up (the spherical
// rectangle's corner normals and solid angle, the cone's frame) is done once, then each
// sample costs a few trigonometric calls (AreaLight::sample_direction for the estimators).
class LightPointSampler {
 public:
  LightPointSampler(const AreaLight& light, Vec3f p);
  // False if p sees no part of the emitting side (sample() must not be called then).
  bool valid() const { return mode_ != Mode::None; }
  bool sample(Vec2f u, AreaLight::DirectionSample* out) const;

 private:
  enum class Mode { None, SphericalRect, Cone, Area };
  const AreaLight* light_;
  Vec3f p_;
  Mode mode_ = Mode::None;
  // Spherical rectangle (Urena et al. 2013), in the rectangle's frame around p.
  Vec3f x_, y_, z_;
  float z0_ = 0, x0_ = 0, y0_ = 0, x1_ = 0, y1_ = 0, b0_ = 0, b1_ = 0, k_ = 0, solid_angle_ = 0;
  // Cone toward a sphere.
  Frame cone_frame_;
  float cos_max_ = 1, dist2_ = 0;
};

}  // namespace penumbra
