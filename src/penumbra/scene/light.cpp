#include "penumbra/scene/light.h"

#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/core/sampling.h"

namespace penumbra {

const char* to_string(LightShape s) {
  switch (s) {
    case LightShape::Rect: return "rect";
    case LightShape::Disk: return "disk";
    case LightShape::Sphere: return "sphere";
  }
  return "?";
}

float AreaLight::area() const {
  if (shape == LightShape::Rect) return size.x * size.y;
  return kPi * radius * radius;
}

float AreaLight::diameter() const {
  if (shape == LightShape::Rect) return std::sqrt(size.x * size.x + size.y * size.y);
  return 2.0f * radius;
}

float AreaLight::extent_radius() const { return 0.5f * diameter(); }

Vec3f AreaLight::sample_area(Vec2f u) const {
  if (shape == LightShape::Rect)
    return center + frame.s * ((u.x - 0.5f) * size.x) + frame.t * ((u.y - 0.5f) * size.y);
  Vec2f d = square_to_disk_concentric(u);
  return center + frame.s * (d.x * radius) + frame.t * (d.y * radius);
}

Vec3f AreaLight::sample_area_toward(Vec2f u, Vec3f p) const {
  if (shape != LightShape::Sphere) return sample_area(u);
  Vec3f axis = p - center;
  if (length_squared(axis) < 1e-20f) return sample_area(u);
  Frame f = Frame::from_z(axis);
  Vec2f d = square_to_disk_concentric(u);
  return center + f.s * (d.x * radius) + f.t * (d.y * radius);
}

bool AreaLight::faces(Vec3f p) const {
  if (shape == LightShape::Sphere) return length_squared(p - center) > radius * radius;
  return dot(p - center, frame.n) > 0.0f;
}

namespace {

// Irradiance factor of a convex polygon of unit radiance at p with normal n: Lambert's
// formula E = 1/2 * sum_i theta_i (n . gamma_i) over the polygon clipped to n's
// hemisphere (the part below the horizon contributes nothing).
double polygon_irradiance(const std::vector<Vec3f>& poly, Vec3f p, Vec3f n) {
  struct V3 { double x, y, z; };
  auto sub = [](Vec3f a, Vec3f b) { return V3{double(a.x) - b.x, double(a.y) - b.y, double(a.z) - b.z}; };
  auto ddot = [](V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; };
  V3 nn{n.x, n.y, n.z};
  // Clip against dot(v, n) >= 0 (Sutherland-Hodgman, one plane).
  std::vector<V3> in, out;
  for (Vec3f q : poly) in.push_back(sub(q, p));
  for (size_t i = 0; i < in.size(); ++i) {
    V3 a = in[i], b = in[(i + 1) % in.size()];
    double da = ddot(a, nn), db = ddot(b, nn);
    if (da >= 0) out.push_back(a);
    if ((da >= 0) != (db >= 0)) {
      double t = da / (da - db);
      out.push_back({a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), a.z + t * (b.z - a.z)});
    }
  }
  if (out.size() < 3) return 0.0;
  double sum = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    V3 a = out[i], b = out[(i + 1) % out.size()];
    double la = std::sqrt(ddot(a, a)), lb = std::sqrt(ddot(b, b));
    if (la < 1e-12 || lb < 1e-12) continue;
    V3 c{a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
    double lc = std::sqrt(ddot(c, c));
    if (lc < 1e-15) continue;
    double theta = std::acos(std::clamp(ddot(a, b) / (la * lb), -1.0, 1.0));
    sum += theta * ddot(c, nn) / lc;
  }
  return 0.5 * std::abs(sum);
}

}  // namespace

std::vector<Vec3f> AreaLight::outline(int segments) const {
  if (shape == LightShape::Rect) {
    Vec3f hs = frame.s * (0.5f * size.x), ht = frame.t * (0.5f * size.y);
    return {center - hs - ht, center + hs - ht, center + hs + ht, center - hs + ht};
  }
  // A polygon circumscribing the circle, so it contains the whole light.
  float r = radius / std::cos(kPi / segments);
  std::vector<Vec3f> poly;
  for (int i = 0; i < segments; ++i) {
    float phi = 2 * kPi * i / segments;
    poly.push_back(center + frame.s * (r * std::cos(phi)) + frame.t * (r * std::sin(phi)));
  }
  return poly;
}

bool AreaLight::sample_direction(Vec3f p, Vec2f u, DirectionSample* out) const {
  LightPointSampler sampler(*this, p);
  return sampler.valid() && sampler.sample(u, out);
}

LightPointSampler::LightPointSampler(const AreaLight& light, Vec3f p) : light_(&light), p_(p) {
  if (!light.faces(p)) return;
  if (light.shape == LightShape::Sphere) {
    Vec3f to_c = light.center - p;
    dist2_ = length_squared(to_c);
    cos_max_ = std::sqrt(std::max(0.0f, 1 - light.radius * light.radius / dist2_));
    cone_frame_ = Frame::from_z(to_c / std::sqrt(dist2_));
    mode_ = Mode::Cone;
    return;
  }
  mode_ = Mode::Area;
  if (light.shape != LightShape::Rect) return;
  // Spherical rectangle set-up (Urena, Fajardo, King 2013, "An Area-Preserving
  // Parametrization for Spherical Rectangles", Algorithm 1): the rectangle's frame with p
  // at the origin, the four corner planes and the solid angle.
  Vec3f ex = light.frame.s * light.size.x, ey = light.frame.t * light.size.y;
  Vec3f corner = light.center - ex * 0.5f - ey * 0.5f;
  x_ = light.frame.s;
  y_ = light.frame.t;
  z_ = cross(x_, y_);
  Vec3f d = corner - p;
  z0_ = dot(d, z_);
  if (z0_ > 0) { z_ = -z_; z0_ = -z0_; }
  x0_ = dot(d, x_); y0_ = dot(d, y_);
  x1_ = x0_ + light.size.x; y1_ = y0_ + light.size.y;
  Vec3f v00(x0_, y0_, z0_), v01(x0_, y1_, z0_), v10(x1_, y0_, z0_), v11(x1_, y1_, z0_);
  Vec3f n0 = normalize(cross(v00, v10)), n1 = normalize(cross(v10, v11));
  Vec3f n2 = normalize(cross(v11, v01)), n3 = normalize(cross(v01, v00));
  float g0 = std::acos(std::clamp(-dot(n0, n1), -1.0f, 1.0f));
  float g1 = std::acos(std::clamp(-dot(n1, n2), -1.0f, 1.0f));
  float g2 = std::acos(std::clamp(-dot(n2, n3), -1.0f, 1.0f));
  float g3 = std::acos(std::clamp(-dot(n3, n0), -1.0f, 1.0f));
  b0_ = n0.z; b1_ = n2.z;
  k_ = 2 * kPi - g2 - g3;
  solid_angle_ = g0 + g1 - k_;
  // Too small a solid angle for the parametrisation to be accurate: sample by area.
  if (std::isfinite(solid_angle_) && solid_angle_ > 1e-5f && -z0_ > 1e-6f) mode_ = Mode::SphericalRect;
}

bool LightPointSampler::sample(Vec2f u, AreaLight::DirectionSample* out) const {
  const AreaLight& light = *light_;
  switch (mode_) {
    case Mode::None:
      return false;
    case Mode::Cone: {
      Vec3f dir = cone_frame_.to_world(square_to_cone(u, cos_max_));
      // Distance to the near intersection with the sphere.
      float b = dot(dir, light.center - p_);
      float disc = b * b - (dist2_ - light.radius * light.radius);
      out->dir = dir;
      out->dist = b - std::sqrt(std::max(0.0f, disc));
      out->pdf = cone_pdf(cos_max_);
      out->area_weight = 1.0f;  // visibility of a sphere: the fraction of its solid angle
      return true;
    }
    case Mode::SphericalRect: {
      float au = u.x * solid_angle_ + k_;
      float fu = (std::cos(au) * b0_ - b1_) / std::sin(au);
      float cu = std::copysign(1.0f, fu) / std::sqrt(fu * fu + b0_ * b0_);
      cu = std::clamp(cu, -1.0f, 1.0f);
      float xu = -(cu * z0_) / std::sqrt(std::max(1e-12f, 1 - cu * cu));
      xu = std::clamp(xu, x0_, x1_);
      float d = std::sqrt(xu * xu + z0_ * z0_);
      float h0 = y0_ / std::sqrt(d * d + y0_ * y0_), h1 = y1_ / std::sqrt(d * d + y1_ * y1_);
      float hv = h0 + u.y * (h1 - h0), hv2 = hv * hv;
      float yv = hv2 < 1 - 1e-6f ? (hv * d) / std::sqrt(1 - hv2) : y1_;
      yv = std::clamp(yv, y0_, y1_);
      Vec3f q = p_ + x_ * xu + y_ * yv + z_ * z0_;
      Vec3f dq = q - p_;
      float dist = length(dq);
      out->dir = dq / dist;
      out->dist = dist;
      out->pdf = 1.0f / solid_angle_;
      float cos_l = std::abs(dot(out->dir, light.frame.n));
      // p_A expressed per solid angle: dist^2 / (A cos_l); its ratio to 1/Omega.
      out->area_weight = cos_l > 1e-8f ? dist * dist / (light.area() * cos_l) * solid_angle_ : 0.0f;
      return true;
    }
    case Mode::Area: {
      // Disks (and degenerate rects): uniform area sampling converted to solid angle.
      Vec3f q = light.sample_area(u);
      Vec3f d = q - p_;
      float dist = length(d);
      if (dist < 1e-12f) return false;
      out->dir = d / dist;
      out->dist = dist;
      float cos_l = std::abs(dot(out->dir, light.frame.n));
      if (cos_l < 1e-8f) return false;
      out->pdf = dist * dist / (light.area() * cos_l);
      out->area_weight = 1.0f;
      return true;
    }
  }
  return false;
}

float AreaLight::unshadowed_irradiance_scalar(Vec3f p, Vec3f n) const {
  if (!faces(p)) return 0.0f;
  if (shape == LightShape::Rect) return static_cast<float>(polygon_irradiance(outline(), p, n));
  if (shape == LightShape::Disk) {
    // A 256-gon inscribed in the disk, rescaled to the disk's area: the relative error
    // of the irradiance is below 1e-4 for any point.
    const int segs = 256;
    float r = radius * std::sqrt((2 * kPi / segs) / std::sin(2 * kPi / segs));
    std::vector<Vec3f> poly;
    for (int i = 0; i < segs; ++i) {
      float phi = 2 * kPi * i / segs;
      poly.push_back(center + frame.s * (r * std::cos(phi)) + frame.t * (r * std::sin(phi)));
    }
    return static_cast<float>(polygon_irradiance(poly, p, n));
  }
  // Sphere: pi sin^2(alpha) cos(theta) when the whole cap is above the horizon.
  Vec3f to_c = center - p;
  float d2 = length_squared(to_c), d = std::sqrt(d2);
  float sin2 = radius * radius / d2, sin_a = std::sqrt(sin2);
  float cos_t = dot(n, to_c / d);
  if (cos_t >= sin_a) return kPi * sin2 * cos_t;
  if (cos_t <= -sin_a) return 0.0f;
  // Straddling the horizon: deterministic stratified quadrature over the cone.
  float cos_max = std::sqrt(std::max(0.0f, 1 - sin2));
  Frame f = Frame::from_z(to_c / d);
  const int k = 64;
  double sum = 0;
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      Vec3f w = f.to_world(square_to_cone({(i + 0.5f) / k, (j + 0.5f) / k}, cos_max));
      sum += std::max(0.0f, dot(w, n));
    }
  return static_cast<float>(sum / (k * k) / cone_pdf(cos_max));
}

}  // namespace penumbra
