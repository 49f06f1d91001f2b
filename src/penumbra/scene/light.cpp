#include "penumbra/scene/light.h"

#include <array>
#include <cmath>
#include <span>

#include "penumbra/core/error.h"
#include "penumbra/core/sampling.h"

namespace penumbra {

const char* to_string(LightShape s) {
  switch (s) {
    case LightShape::Rect: return "rect";
    case LightShape::Disk: return "disk";
    case LightShape::Sphere: return "sphere";
    case LightShape::Ellipsoid: return "ellipsoid";
  }
  return "?";
}

float AreaLight::area() const {
  switch (shape) {
    case LightShape::Rect: return size.x * size.y;
    case LightShape::Disk:
    case LightShape::Sphere: return kPi * radius * radius;
    case LightShape::Ellipsoid: return kPi * radii.x * radii.y;
  }
  return 0.0f;
}

float AreaLight::diameter() const {
  switch (shape) {
    case LightShape::Rect: return std::sqrt(size.x * size.x + size.y * size.y);
    case LightShape::Disk:
    case LightShape::Sphere: return 2.0f * radius;
    case LightShape::Ellipsoid: return 2.0f * std::max(radii.x, std::max(radii.y, radii.z));
  }
  return 0.0f;
}

float AreaLight::extent_radius() const { return 0.5f * diameter(); }

LightTexture::LightTexture(std::shared_ptr<const Texture> img) : image(std::move(img)) {
  const int w = image->width(), h = image->height();
  // Tables with row 0 at v = 0: the image's bottom row.
  std::vector<float> values[4];
  for (auto& v : values) v.resize(static_cast<size_t>(w) * h);
  double sum[3] = {0, 0, 0};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float* t = &image->rgba()[(static_cast<size_t>(h - 1 - y) * w + x) * 4];
      const size_t i = static_cast<size_t>(y) * w + x;
      for (int c = 0; c < 3; ++c) {
        if (!std::isfinite(t[c])) throw Error("{}: texel ({}, {}) is not finite", image->name(), x, h - 1 - y);
        values[c][i] = std::max(0.0f, t[c]);
        sum[c] += values[c][i];
      }
      values[3][i] = penumbra::luminance(Vec3f(values[0][i], values[1][i], values[2][i]));
    }
  for (int c = 0; c < 3; ++c) channel[c] = PiecewiseConstant2D(values[c], w, h);
  luminance = PiecewiseConstant2D(values[3], w, h);
  const double n = static_cast<double>(w) * h;
  mean = Vec3f(static_cast<float>(sum[0] / n), static_cast<float>(sum[1] / n), static_cast<float>(sum[2] / n));
}

std::vector<AreaLight> expand_textured_lights(std::span<const AreaLight> lights) {
  std::vector<AreaLight> out;
  for (const AreaLight& l : lights) {
    if (!l.textured() || l.texture_channel >= 0) {
      out.push_back(l);
      continue;
    }
    const size_t first = out.size();
    for (int c = 0; c < 3; ++c) {
      const float r = l.radiance[c] * l.texture->mean[c];
      if (!(r > 0)) continue;
      AreaLight channel = l;
      channel.radiance = Vec3f(0.0f);
      channel.radiance[c] = r;
      channel.texture_channel = c;
      out.push_back(channel);
    }
    if (out.size() == first) {  // a black light: one light of zero radiance
      AreaLight black = l;
      black.radiance = Vec3f(0.0f);
      black.texture_channel = 0;
      out.push_back(black);
    }
  }
  return out;
}

Vec3f AreaLight::sample_area(Vec2f u) const {
  if (textured()) u = texture->table(texture_channel).sample(u);
  if (shape == LightShape::Rect)
    return center + frame.s * ((u.x - 0.5f) * size.x) + frame.t * ((u.y - 0.5f) * size.y);
  Vec2f d = square_to_disk_concentric(u);
  if (shape == LightShape::Ellipsoid) return center + frame.s * (d.x * radii.x) + frame.t * (d.y * radii.y);
  return center + frame.s * (d.x * radius) + frame.t * (d.y * radius);
}

Vec3f AreaLight::from_unit_sphere(Vec3f x) const {
  return center + frame.s * (x.x * radii.x) + frame.t * (x.y * radii.y) + frame.n * (x.z * radii.z);
}

Vec3f AreaLight::to_unit_sphere(Vec3f p) const {
  const Vec3f l = frame.to_local(p - center);
  return {l.x / radii.x, l.y / radii.y, l.z / radii.z};
}

AreaLight::Ellipse AreaLight::section_toward(Vec3f p) const {
  // The unit sphere's central disk perpendicular to A^-1(p), mapped by A.
  const Vec3f axis = to_unit_sphere(p);
  const Frame f = length_squared(axis) < 1e-20f ? Frame() : Frame::from_z(axis);
  auto linear = [&](Vec3f x) { return from_unit_sphere(x) - center; };
  Ellipse e;
  e.center = center;
  e.a = linear(f.s);
  e.b = linear(f.t);
  const Vec3f n = cross(e.a, e.b);
  const float len = length(n);
  e.normal = n / len;
  e.area = kPi * len;
  return e;
}

AreaLight::Ellipse AreaLight::contour_toward(Vec3f p) const {
  const Vec3f pu = to_unit_sphere(p);
  const float d2 = std::max(length_squared(pu), 1.0f);
  const Frame f = Frame::from_z(pu);
  const float rho = std::sqrt(std::max(0.0f, 1 - 1 / d2));
  auto linear = [&](Vec3f x) { return from_unit_sphere(x) - center; };
  Ellipse e;
  e.center = from_unit_sphere(pu / d2);
  e.a = linear(f.s * rho);
  e.b = linear(f.t * rho);
  const Vec3f n = cross(e.a, e.b);
  const float len = length(n);
  e.normal = len > 0 ? n / len : f.n;
  e.area = kPi * len;
  return e;
}

Vec3f AreaLight::sample_area_toward(Vec2f u, Vec3f p) const {
  if (shape == LightShape::Ellipsoid) {
    const Ellipse e = section_toward(p);
    const Vec2f d = square_to_disk_concentric(u);
    return center + e.a * d.x + e.b * d.y;
  }
  if (shape != LightShape::Sphere) return sample_area(u);
  Vec3f axis = p - center;
  if (length_squared(axis) < 1e-20f) return sample_area(u);
  Frame f = Frame::from_z(axis);
  Vec2f d = square_to_disk_concentric(u);
  return center + f.s * (d.x * radius) + f.t * (d.y * radius);
}

bool AreaLight::faces(Vec3f p) const {
  if (shape == LightShape::Sphere) return length_squared(p - center) > radius * radius;
  if (shape == LightShape::Ellipsoid) return length_squared(to_unit_sphere(p)) > 1.0f;
  return dot(p - center, frame.n) > 0.0f;
}

namespace {

// Irradiance factor of a convex polygon of unit radiance at p with normal n: Lambert's
// formula E = 1/2 * sum_i theta_i (n . gamma_i) over the polygon clipped to n's
// hemisphere (the part below the horizon contributes nothing). Called once per view sample
// by the renderer's compose loop, so it works on the stack (kMaxPolygon vertices).
constexpr size_t kMaxPolygon = 256;
double polygon_irradiance(std::span<const Vec3f> poly, Vec3f p, Vec3f n) {
  struct V3 { double x, y, z; };
  auto sub = [](Vec3f a, Vec3f b) { return V3{double(a.x) - b.x, double(a.y) - b.y, double(a.z) - b.z}; };
  auto ddot = [](V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; };
  if (poly.size() > kMaxPolygon) throw Error("polygon_irradiance: {} vertices (at most {})", poly.size(), kMaxPolygon);
  V3 nn{n.x, n.y, n.z};
  // Clip against dot(v, n) >= 0 (Sutherland-Hodgman, one plane: a convex polygon gains at
  // most one vertex).
  std::array<V3, kMaxPolygon> in;
  std::array<V3, kMaxPolygon + 1> out;
  const size_t count = poly.size();
  size_t m = 0;
  for (size_t i = 0; i < count; ++i) in[i] = sub(poly[i], p);
  for (size_t i = 0; i < count; ++i) {
    V3 a = in[i], b = in[(i + 1) % count];
    double da = ddot(a, nn), db = ddot(b, nn);
    if (da >= 0) out[m++] = a;
    if ((da >= 0) != (db >= 0)) {
      double t = da / (da - db);
      out[m++] = {a.x + t * (b.x - a.x), a.y + t * (b.y - a.y), a.z + t * (b.z - a.z)};
    }
  }
  if (m < 3) return 0.0;
  double sum = 0;
  for (size_t i = 0; i < m; ++i) {
    V3 a = out[i], b = out[(i + 1) % m];
    V3 c{a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
    double lc = std::sqrt(ddot(c, c));
    if (lc < 1e-15) continue;  // an edge through p, or a degenerate one
    // theta = atan2(|a x b|, a . b): accurate for the small angles of far lights, where
    // acos(a . b / (|a| |b|)) loses half its digits (light_kernels::rect_irradiance does the same).
    double theta = std::atan2(lc, ddot(a, b));
    sum += theta * ddot(c, nn) / lc;
  }
  return 0.5 * std::abs(sum);
}

// cos and sin of 2 pi i / 256, i < 256, computed once (as float, as the polygons use them).
const std::array<Vec2f, 256>& unit_circle_256() {
  static const std::array<Vec2f, 256> table = [] {
    std::array<Vec2f, 256> t;
    for (int i = 0; i < 256; ++i) {
      const float phi = 2 * kPi * i / 256;
      t[i] = Vec2f(std::cos(phi), std::sin(phi));
    }
    return t;
  }();
  return table;
}

}  // namespace

void AreaLight::unshadowed_irradiance_scalar(std::span<const Vec3f> p, std::span<const Vec3f> n,
                                             std::span<float> out) const {
  if (n.size() < p.size() || out.size() < p.size())
    throw Error("AreaLight::unshadowed_irradiance_scalar: {} points, {} normals, {} outputs", p.size(), n.size(),
                out.size());
  if (shape != LightShape::Rect) {
    for (size_t i = 0; i < p.size(); ++i) out[i] = unshadowed_irradiance_scalar(p[i], n[i]);
    return;
  }
  // Rects: the SIMD kernel (clipping included) over chunks of points in structure-of-arrays form.
  const Vec3f hs = frame.s * (0.5f * size.x), ht = frame.t * (0.5f * size.y);
  const Vec3f c[4] = {center - hs - ht, center + hs - ht, center + hs + ht, center - hs + ht};  // as outline()
  double corners[4][3];
  for (int k = 0; k < 4; ++k) corners[k][0] = c[k].x, corners[k][1] = c[k].y, corners[k][2] = c[k].z;
  constexpr size_t kChunk = 256;
  static_assert(kChunk % LightSampleBatch::kLanePad == 0);
  alignas(64) float px[kChunk], py[kChunk], pz[kChunk], nx[kChunk], ny[kChunk], nz[kChunk], e[kChunk];
  for (size_t begin = 0; begin < p.size(); begin += kChunk) {
    const size_t count = std::min(kChunk, p.size() - begin);
    const size_t padded = (count + LightSampleBatch::kLanePad - 1) / LightSampleBatch::kLanePad * LightSampleBatch::kLanePad;
    for (size_t i = 0; i < padded; ++i) {
      const Vec3f q = i < count ? p[begin + i] : Vec3f(0.0f), m = i < count ? n[begin + i] : Vec3f(0.0f);
      px[i] = q.x, py[i] = q.y, pz[i] = q.z, nx[i] = m.x, ny[i] = m.y, nz[i] = m.z;
    }
    light_kernels::rect_irradiance(corners, px, py, pz, nx, ny, nz, padded, e);
    for (size_t i = 0; i < count; ++i) out[begin + i] = faces(p[begin + i]) ? e[i] : 0.0f;
  }
}

std::vector<Vec3f> AreaLight::outline(int segments) const {
  if (shape == LightShape::Rect) {
    Vec3f hs = frame.s * (0.5f * size.x), ht = frame.t * (0.5f * size.y);
    return {center - hs - ht, center + hs - ht, center + hs + ht, center - hs + ht};
  }
  // A polygon circumscribing the circle, so it contains the whole light (for an ellipsoid,
  // A of the unit circle's: affine maps keep convexity and containment).
  const float r = 1.0f / std::cos(kPi / segments);
  const float rs = shape == LightShape::Ellipsoid ? radii.x : radius;
  const float rt = shape == LightShape::Ellipsoid ? radii.y : radius;
  std::vector<Vec3f> poly;
  for (int i = 0; i < segments; ++i) {
    float phi = 2 * kPi * i / segments;
    poly.push_back(center + frame.s * (rs * r * std::cos(phi)) + frame.t * (rt * r * std::sin(phi)));
  }
  return poly;
}

bool AreaLight::sample_direction(Vec3f p, Vec2f u, DirectionSample* out) const {
  LightPointSampler sampler(*this, p);
  return sampler.valid() && sampler.sample(u, out);
}

namespace {
void store(float out[3], Vec3f v) { out[0] = v.x; out[1] = v.y; out[2] = v.z; }
Vec3f load(const float v[3]) { return {v[0], v[1], v[2]}; }
}  // namespace

LightPointSampler::LightPointSampler(const AreaLight& light, Vec3f p) : light_(&light), p_(p) {
  if (!light.faces(p)) return;
  if (light.shape == LightShape::Sphere) {
    Vec3f to_c = light.center - p;
    dist2_ = length_squared(to_c);
    cone_.cos_max = std::sqrt(std::max(0.0f, 1 - light.radius * light.radius / dist2_));
    const Frame f = Frame::from_z(to_c / std::sqrt(dist2_));
    store(cone_.s, f.s);
    store(cone_.t, f.t);
    store(cone_.n, f.n);
    store(cone_.to_center, to_c);
    cone_.dist2_minus_r2 = dist2_ - light.radius * light.radius;
    cone_.inv_pdf = 1.0f / cone_pdf(cone_.cos_max);
    mode_ = Mode::Cone;
    return;
  }
  if (light.shape == LightShape::Ellipsoid) {
    // Uniform area samples on the contour ellipse: the directions cover exactly the tangent
    // cone (the irradiance estimate is unbiased), and the weights below make V the fraction of
    // the cone's solid angle p sees, as the cone does for a sphere.
    ellipse_ = light.contour_toward(p);
    if (!(ellipse_.area > 0)) return;
    dist2_ = length_squared(ellipse_.center - p);
    contour_cos_ = std::abs(dot(normalize(ellipse_.center - p), ellipse_.normal));
    mode_ = Mode::Ellipse;
    return;
  }
  mode_ = Mode::Area;
  // A textured rect: area samples through its table, weighted as uniform ones (sample_area).
  if (light.shape != LightShape::Rect || light.textured()) return;
  // Spherical rectangle set-up (Urena, Fajardo, King 2013, "An Area-Preserving
  // Parametrization for Spherical Rectangles", Algorithm 1): the rectangle's frame with p
  // at the origin, the four corner planes and the solid angle.
  light_kernels::SphericalRect& r = rect_;
  Vec3f ex = light.frame.s * light.size.x, ey = light.frame.t * light.size.y;
  Vec3f corner = light.center - ex * 0.5f - ey * 0.5f;
  Vec3f x = light.frame.s, y = light.frame.t, z = cross(x, y);
  Vec3f d = corner - p;
  r.z0 = dot(d, z);
  if (r.z0 > 0) { z = -z; r.z0 = -r.z0; }
  store(r.x, x);
  store(r.y, y);
  store(r.z, z);
  r.x0 = dot(d, x); r.y0 = dot(d, y);
  r.x1 = r.x0 + light.size.x; r.y1 = r.y0 + light.size.y;
  Vec3f v00(r.x0, r.y0, r.z0), v01(r.x0, r.y1, r.z0), v10(r.x1, r.y0, r.z0), v11(r.x1, r.y1, r.z0);
  Vec3f n0 = normalize(cross(v00, v10)), n1 = normalize(cross(v10, v11));
  Vec3f n2 = normalize(cross(v11, v01)), n3 = normalize(cross(v01, v00));
  float g0 = std::acos(std::clamp(-dot(n0, n1), -1.0f, 1.0f));
  float g1 = std::acos(std::clamp(-dot(n1, n2), -1.0f, 1.0f));
  float g2 = std::acos(std::clamp(-dot(n2, n3), -1.0f, 1.0f));
  float g3 = std::acos(std::clamp(-dot(n3, n0), -1.0f, 1.0f));
  r.b0 = n0.z; r.b1 = n2.z;
  r.k = 2 * kPi - g2 - g3;
  r.solid_angle = g0 + g1 - r.k;
  r.inv_area = 1.0f / light.area();
  // Too small a solid angle for the parametrisation to be accurate: sample by area.
  if (std::isfinite(r.solid_angle) && r.solid_angle > 1e-5f && -r.z0 > 1e-6f) mode_ = Mode::SphericalRect;
}

int LightPointSampler::sample_batch(const float* ux, const float* uy, int n, LightSampleBatch& out) const {
  out.resize(n);
  if (mode_ == Mode::SphericalRect) {
    light_kernels::sample_spherical_rect(rect_, ux, uy, static_cast<size_t>(n), out);
    return n;
  }
  if (mode_ == Mode::Cone) {
    light_kernels::sample_cone(cone_, ux, uy, static_cast<size_t>(n), out);
    return n;
  }
  int m = 0;
  for (int i = 0; i < n; ++i) {
    AreaLight::DirectionSample ds;
    if (!sample({ux[i], uy[i]}, &ds)) continue;
    out.x[m] = ds.dir.x * ds.dist;
    out.y[m] = ds.dir.y * ds.dist;
    out.z[m] = ds.dir.z * ds.dist;
    out.dist[m] = ds.dist;
    out.inv_pdf[m] = 1.0f / ds.pdf;
    out.area_weight[m] = ds.area_weight;
    ++m;
  }
  return m;
}

bool LightPointSampler::sample(Vec2f u, AreaLight::DirectionSample* out) const {
  const AreaLight& light = *light_;
  switch (mode_) {
    case Mode::None:
      return false;
    case Mode::Cone: {
      const Frame f(load(cone_.s), load(cone_.t), load(cone_.n));
      Vec3f dir = f.to_world(square_to_cone(u, cone_.cos_max));
      // Distance to the near intersection with the sphere.
      float b = dot(dir, light.center - p_);
      float disc = b * b - (dist2_ - light.radius * light.radius);
      out->dir = dir;
      out->dist = b - std::sqrt(std::max(0.0f, disc));
      out->pdf = cone_pdf(cone_.cos_max);
      out->area_weight = 1.0f;  // visibility of a sphere: the fraction of its solid angle
      return true;
    }
    case Mode::SphericalRect: {
      const light_kernels::SphericalRect& r = rect_;
      float au = u.x * r.solid_angle + r.k;
      float fu = (std::cos(au) * r.b0 - r.b1) / std::sin(au);
      float cu = std::copysign(1.0f, fu) / std::sqrt(fu * fu + r.b0 * r.b0);
      cu = std::clamp(cu, -1.0f, 1.0f);
      float xu = -(cu * r.z0) / std::sqrt(std::max(1e-12f, 1 - cu * cu));
      xu = std::clamp(xu, r.x0, r.x1);
      float d = std::sqrt(xu * xu + r.z0 * r.z0);
      float h0 = r.y0 / std::sqrt(d * d + r.y0 * r.y0), h1 = r.y1 / std::sqrt(d * d + r.y1 * r.y1);
      float hv = h0 + u.y * (h1 - h0), hv2 = hv * hv;
      float yv = hv2 < 1 - 1e-6f ? (hv * d) / std::sqrt(1 - hv2) : r.y1;
      yv = std::clamp(yv, r.y0, r.y1);
      Vec3f q = p_ + load(r.x) * xu + load(r.y) * yv + load(r.z) * r.z0;
      Vec3f dq = q - p_;
      float dist = length(dq);
      out->dir = dq / dist;
      out->dist = dist;
      out->pdf = 1.0f / r.solid_angle;
      float cos_l = std::abs(dot(out->dir, light.frame.n));
      // p_A expressed per solid angle: dist^2 / (A cos_l); its ratio to 1/Omega.
      out->area_weight = cos_l > 1e-8f ? dist * dist / (light.area() * cos_l) * r.solid_angle : 0.0f;
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
    case Mode::Ellipse: {
      const Vec2f e = square_to_disk_concentric(u);
      const Vec3f d = ellipse_.center + ellipse_.a * e.x + ellipse_.b * e.y - p_;
      const float dist = length(d);
      if (dist < 1e-12f) return false;
      out->dir = d / dist;
      out->dist = dist;
      const float cos_l = std::abs(dot(out->dir, ellipse_.normal));
      if (cos_l < 1e-8f) return false;
      out->pdf = dist * dist / (ellipse_.area * cos_l);
      // Uniform solid angle over the cone relative to this density, up to a constant (the
      // estimate is self-normalised): 1/pdf, scaled to about 1 by the centre's value.
      out->area_weight = cos_l * dist2_ / (dist * dist * contour_cos_);
      return true;
    }
  }
  return false;
}

float AreaLight::unshadowed_irradiance_scalar(Vec3f p, Vec3f n) const {
  if (!faces(p)) return 0.0f;
  if (shape == LightShape::Rect) {
    const Vec3f hs = frame.s * (0.5f * size.x), ht = frame.t * (0.5f * size.y);
    const Vec3f corners[4] = {center - hs - ht, center + hs - ht, center + hs + ht, center - hs + ht};  // as outline()
    return static_cast<float>(polygon_irradiance(corners, p, n));
  }
  if (shape == LightShape::Disk) {
    // A 256-gon inscribed in the disk, rescaled to the disk's area: the relative error
    // of the irradiance is below 1e-4 for any point.
    const int segs = 256;
    float r = radius * std::sqrt((2 * kPi / segs) / std::sin(2 * kPi / segs));
    std::array<Vec3f, segs> poly;
    const auto& circle = unit_circle_256();
    for (int i = 0; i < segs; ++i) poly[i] = center + frame.s * (r * circle[i].x) + frame.t * (r * circle[i].y);
    return static_cast<float>(polygon_irradiance(poly, p, n));
  }
  if (shape == LightShape::Ellipsoid) {
    // The tangent cone from p: in the unit sphere's space the silhouette seen from p' =
    // A^-1(p) is the circle of radius sqrt(1 - 1/d'^2) around p'/d'^2 perpendicular to p';
    // A maps it onto the ellipsoid's contour seen from p (affine maps keep lines through p
    // and tangency). A 256-gon inscribed in it, rescaled to the ellipse's area as for disks.
    const Ellipse e = contour_toward(p);
    const int segs = 256;
    const float scale = std::sqrt((2 * kPi / segs) / std::sin(2 * kPi / segs));
    std::array<Vec3f, segs> poly;
    const auto& circle = unit_circle_256();
    for (int i = 0; i < segs; ++i) poly[i] = e.center + (e.a * circle[i].x + e.b * circle[i].y) * scale;
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
