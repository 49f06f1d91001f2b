#include "penumbra/scene/light.h"

#include <algorithm>
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

namespace {

bool inside(const Bounds3f& b, Vec3f p) {
  return p.x >= b.lo.x && p.x <= b.hi.x && p.y >= b.lo.y && p.y <= b.hi.y && p.z >= b.lo.z && p.z <= b.hi.z;
}

// Whether the cone of directions leaving the cube around `apex` through the face of axis `a`
// (side axes b, c: a.d >= |b.d|, a.d >= |c.d|) meets the box: the separating axis test of two
// convex polytopes, the cone cut off beyond the box (a pyramid of apex `apex`).
bool face_cone_meets_box(Vec3f apex, Vec3f a, Vec3f b, Vec3f c, const Bounds3f& box) {
  float reach = 0;
  for (int i = 0; i < 8; ++i) reach = std::max(reach, length(box.corner(i) - apex));
  const float h = reach * 1.01f + 1e-6f;
  const std::array<Vec3f, 5> pyramid = {apex, apex + (a + b + c) * h, apex + (a + b - c) * h, apex + (a - b - c) * h,
                                        apex + (a - b + c) * h};
  std::array<Vec3f, 8> corners;
  for (int i = 0; i < 8; ++i) corners[i] = box.corner(i);
  const std::array<Vec3f, 3> box_edges = {Vec3f(1, 0, 0), Vec3f(0, 1, 0), Vec3f(0, 0, 1)};
  const std::array<Vec3f, 6> pyramid_edges = {a + b + c, a + b - c, a - b - c, a - b + c, b, c};
  std::vector<Vec3f> axes(box_edges.begin(), box_edges.end());
  axes.push_back(a);
  for (int k = 0; k < 4; ++k)  // the pyramid's lateral faces
    axes.push_back(cross(pyramid[1 + k] - apex, pyramid[1 + (k + 1) % 4] - apex));
  for (Vec3f e : box_edges)
    for (Vec3f f : pyramid_edges) axes.push_back(cross(e, f));
  for (Vec3f axis : axes) {
    if (!(length_squared(axis) > 1e-20f)) continue;
    float lo0 = kInfinity, hi0 = -kInfinity, lo1 = kInfinity, hi1 = -kInfinity;
    for (Vec3f v : pyramid) lo0 = std::min(lo0, dot(v, axis)), hi0 = std::max(hi0, dot(v, axis));
    for (Vec3f v : corners) lo1 = std::min(lo1, dot(v, axis)), hi1 = std::max(hi1, dot(v, axis));
    if (hi0 < lo1 || hi1 < lo0) return false;
  }
  return true;
}

}  // namespace

std::vector<AreaLight> split_sphere_lights(std::span<const AreaLight> lights, const Bounds3f& scene_bounds) {
  std::vector<AreaLight> out;
  for (const AreaLight& l : lights) {
    bool behind = false;  // some of the scene behind the plane of the disk the methods sample
    const bool round = l.shape == LightShape::Sphere || l.shape == LightShape::Ellipsoid;
    if (round && l.split_face < 0 && !scene_bounds.empty())
      for (int i = 0; i < 8; ++i) behind = behind || dot(scene_bounds.corner(i) - l.center, l.frame.n) < 0.0f;
    if (!behind) {
      out.push_back(l);
      continue;
    }
    // The faces in sphere_face's order: +n, -n, +s, -s, +t, -t; each face's light gets a
    // right-handed frame with n along the face's axis, and is kept where its cone of the cube
    // reaches the scene's bounds. Outside the bounds, face 0 is the light as it was, serving the
    // whole half-space in front. An ellipsoid's frame is its semi-axes': each face describes the
    // same ellipsoid, its radii permuted with the axes, and samples its central ellipse facing
    // the face's axis.
    const bool cube = inside(scene_bounds, l.center);
    const Frame& f = l.frame;
    const std::array<Frame, 6> faces = {Frame(f.s, f.t, f.n),   Frame(f.t, f.s, -f.n), Frame(f.t, f.n, f.s),
                                        Frame(f.n, f.t, -f.s), Frame(f.n, f.s, f.t),  Frame(f.s, f.n, -f.t)};
    const Vec3f r = l.radii;
    const std::array<Vec3f, 6> radii = {r, Vec3f(r.y, r.x, r.z), Vec3f(r.y, r.z, r.x),
                                        Vec3f(r.z, r.y, r.x), Vec3f(r.z, r.x, r.y), Vec3f(r.x, r.z, r.y)};
    const size_t first = out.size();
    for (int k = 0; k < 6; ++k) {
      if ((cube || k > 0) && !face_cone_meets_box(l.center, faces[k].n, faces[k].s, faces[k].t, scene_bounds))
        continue;
      AreaLight face = l;
      face.frame = faces[k];
      face.radii = radii[k];
      face.split_face = k;
      face.split_cube = cube;
      face.split_frame = f;
      out.push_back(face);
    }
    for (size_t i = first; i < out.size(); ++i) out[i].split_faces = static_cast<int>(out.size() - first);
  }
  return out;
}

float whole_light_count(std::span<const AreaLight> lights) {
  float n = 0;
  for (const AreaLight& l : lights) n += l.split_faces > 0 ? 1.0f / static_cast<float>(l.split_faces) : 1.0f;
  return n;
}

bool has_split_light(std::span<const AreaLight> lights) {
  return std::any_of(lights.begin(), lights.end(), [](const AreaLight& l) { return l.split_face >= 0; });
}

shader::LightGeometry AreaLight::geometry() const {
  shader::LightGeometry g;
  g.center = center;
  g.shape = static_cast<uint32_t>(shape);
  g.s = frame.s;
  g.size_x = size.x;
  g.t = frame.t;
  g.size_y = size.y;
  g.n = frame.n;
  g.radius = radius;
  g.radii = radii;
  g.area = area();
  return g;
}

// The geometry lives in light_shared.h (the GPU kernels include it too); a textured rect first
// warps u through its table.
Vec3f AreaLight::sample_area(Vec2f u) const {
  if (textured()) u = texture->table(texture_channel).sample(u);
  return shader::light_sample_area(geometry(), u);
}

Vec3f AreaLight::from_unit_sphere(Vec3f x) const { return shader::light_from_unit_sphere(geometry(), x); }

Vec3f AreaLight::to_unit_sphere(Vec3f p) const { return shader::light_to_unit_sphere(geometry(), p); }

namespace {
AreaLight::Ellipse ellipse_of(const shader::LightEllipse& e) { return {e.center, e.a, e.b, e.normal, e.area}; }
}  // namespace

AreaLight::Ellipse AreaLight::section_toward(Vec3f p) const {
  return ellipse_of(shader::light_section_toward(geometry(), p));
}

AreaLight::Ellipse AreaLight::contour_toward(Vec3f p) const {
  return ellipse_of(shader::light_contour_toward(geometry(), p));
}

Vec3f AreaLight::sample_area_toward(Vec2f u, Vec3f p) const {
  if (textured()) u = texture->table(texture_channel).sample(u);
  return shader::light_sample_area_toward(geometry(), u, p);
}

bool AreaLight::faces(Vec3f p) const { return shader::light_faces(geometry(), p); }

namespace {

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

const float* unit_circle_table() { return &unit_circle_256()[0].x; }

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
}  // namespace

LightPointSampler::LightPointSampler(const AreaLight& light, Vec3f p)
    : light_(&light), geometry_(light.geometry()), state_(shader::light_sampler_init(geometry_, light.textured(), p)) {
  // The SIMD kernels' copies of the set-up (light_batch.h).
  const shader::LightSampler& s = state_;
  if (s.mode == shader::kSamplerCone) {
    store(cone_.s, s.cs);
    store(cone_.t, s.ct);
    store(cone_.n, s.cn);
    store(cone_.to_center, s.to_center);
    cone_.cos_max = s.cos_max;
    cone_.dist2_minus_r2 = s.dist2_minus_r2;
    cone_.inv_pdf = s.cone_inv_pdf;
  } else if (s.mode == shader::kSamplerSphericalRect) {
    store(rect_.x, s.rx);
    store(rect_.y, s.ry);
    store(rect_.z, s.rz);
    rect_.z0 = s.z0, rect_.x0 = s.x0, rect_.y0 = s.y0, rect_.x1 = s.x1, rect_.y1 = s.y1;
    rect_.b0 = s.b0, rect_.b1 = s.b1, rect_.k = s.k, rect_.solid_angle = s.solid_angle;
    rect_.inv_area = 1.0f / geometry_.area;
  }
}

int LightPointSampler::sample_batch(const float* ux, const float* uy, int n, LightSampleBatch& out) const {
  out.resize(n);
  if (state_.mode == shader::kSamplerSphericalRect) {
    light_kernels::sample_spherical_rect(rect_, ux, uy, static_cast<size_t>(n), out);
    return n;
  }
  if (state_.mode == shader::kSamplerCone) {
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
  // A textured light's area samples follow its table (AreaLight::sample_area).
  if (state_.mode == shader::kSamplerArea && light_->textured())
    u = light_->texture->table(light_->texture_channel).sample(u);
  return shader::light_sampler_sample(state_, geometry_, u, out->dir, out->dist, out->pdf, out->area_weight);
}

float AreaLight::unshadowed_irradiance_scalar(Vec3f p, Vec3f n) const {
  return shader::light_irradiance(geometry(), p, n, unit_circle_table());
}

}  // namespace penumbra
