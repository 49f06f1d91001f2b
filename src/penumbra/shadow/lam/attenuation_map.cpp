#include "penumbra/shadow/lam/attenuation_map.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>

#include "penumbra/core/binary_io.h"
#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/raster/rasterizer.h"
#include "penumbra/scene/scene.h"

namespace penumbra::lam {

// The largest depth change per texel a surface's gradient may have, relative to depth:
// steeper than this (within a few degrees of edge-on) is clamped.
constexpr float kMaxSlope = 0.05f;

LightAxes light_axes(const AreaLight& light) {
  // Exactly what LightView::frustum(eye, n, t, ...) builds, so views and axes agree.
  LightAxes a;
  a.eye = light.center;
  a.forward = normalize(light.frame.n);
  Vec3f s = cross(a.forward, light.frame.t);
  if (!(length_squared(s) > 1e-12f)) {
    Vec3f t, b;
    coordinate_system(a.forward, &t, &b);
    s = t;
  }
  a.right = normalize(s);
  a.up = cross(a.right, a.forward);
  return a;
}

namespace {

// An object's bounds seen from the light centre: the window (at unit depth) and the depth
// range of the part at linear depth >= min_near (as LightView::frustum_fitted clips it).
struct ViewBox {
  bool empty = true;
  float u0 = kInfinity, u1 = -kInfinity, v0 = kInfinity, v1 = -kInfinity;
  float z0 = kInfinity, z1 = 0;
};

ViewBox project_box(const Bounds3f& b, const LightAxes& a, float min_near) {
  ViewBox box;
  const BoxPartBeyondNear part = box_part_beyond_near(b, a.eye, a.right, a.up, a.forward, min_near);
  for (int i = 0; i < part.count; ++i) {
    const Vec3f p = part.points[i];
    box.empty = false;
    box.z0 = std::min(box.z0, p.z);
    box.z1 = std::max(box.z1, p.z);
    box.u0 = std::min(box.u0, p.x / p.z); box.u1 = std::max(box.u1, p.x / p.z);
    box.v0 = std::min(box.v0, p.y / p.z); box.v1 = std::max(box.v1, p.y / p.z);
  }
  return box;
}

bool windows_overlap(const ViewBox& a, float u0, float u1, float v0, float v1) {
  return !a.empty && a.u0 <= u1 && a.u1 >= u0 && a.v0 <= v1 && a.v1 >= v0;
}

// Whether every vertex of the mesh lies on one plane (then the object cannot shadow
// itself); *n and *p0 receive the plane.
bool planar(const TriangleMesh& m, float tol, Vec3f* n, Vec3f* p0) {
  if (m.positions.empty()) return true;
  Vec3f best(0.0f);
  for (size_t t = 0; 3 * t + 2 < m.indices.size(); ++t) {
    Vec3f a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]], c = m.positions[m.indices[3 * t + 2]];
    Vec3f c3 = cross(b - a, c - a);
    if (length_squared(c3) > length_squared(best)) best = c3;
    if (t > 64) break;  // the largest of the first triangles gives a well-conditioned normal
  }
  if (!(length_squared(best) > 0)) return true;  // degenerate: nothing to self-shadow
  *n = normalize(best);
  *p0 = m.positions[m.indices[0]];
  for (Vec3f p : m.positions)
    if (std::abs(dot(p - *p0, *n)) > tol) return false;
  return true;
}

}  // namespace

ShadowRegion fit_shadow_region(const Scene& scene, const AreaLight& light, float max_tan) {
  const LightAxes a = light_axes(light);
  const Bounds3f sb = scene.bounds();
  const float diag = sb.empty() ? 1.0f : std::max(1e-6f, length(sb.diagonal()));
  const float min_near = 1e-3f * diag;
  const float tol = 1e-5f * diag;
  // The light's half-extent along the view axes (an outline circumscribing it).
  float ex = 0, ey = 0;
  const std::vector<Vec3f> outline = light.outline(32);
  for (Vec3f q : outline) {
    ex = std::max(ex, std::abs(dot(q - a.eye, a.right)));
    ey = std::max(ey, std::abs(dot(q - a.eye, a.up)));
  }
  const size_t n = scene.objects.size();
  std::vector<ViewBox> boxes(n);
  std::vector<Bounds3f> bounds(n);
  for (size_t i = 0; i < n; ++i) {
    bounds[i] = scene.objects[i].mesh.bounds();
    boxes[i] = project_box(bounds[i], a, min_near);
  }
  ShadowRegion r;
  r.u0 = r.v0 = kInfinity;
  r.u1 = r.v1 = -kInfinity;
  r.near = kInfinity;
  r.far = 0;
  for (size_t o = 0; o < n; ++o) {
    const ViewBox& c = boxes[o];
    if (c.empty || !(scene.objects[o].material.opacity > 0)) continue;
    // The caster's shadow volume seen from the centre: its window grown by eq. 3 with the
    // largest displacement on the light and the caster's nearest depth.
    float gu = ex / c.z0, gv = ey / c.z0;
    float su0 = std::max(-max_tan, c.u0 - gu), su1 = std::min(max_tan, c.u1 + gu);
    float sv0 = std::max(-max_tan, c.v0 - gv), sv1 = std::min(max_tan, c.v1 + gv);
    if (!(su0 < su1) || !(sv0 < sv1)) continue;
    Vec3f pn, p0;
    const bool flat = planar(scene.objects[o].mesh, tol, &pn, &p0);
    // A planar caster with the whole light on one side shadows only the other side.
    int light_side = 0;
    if (flat && length_squared(pn) > 0) {
      int pos = 0, neg = 0;
      for (Vec3f q : outline) {
        float s = dot(q - p0, pn);
        pos += s > tol;
        neg += s < -tol;
      }
      if (pos == static_cast<int>(outline.size())) light_side = 1;
      if (neg == static_cast<int>(outline.size())) light_side = -1;
    }
    bool any = false;
    float ru0 = kInfinity, ru1 = -kInfinity, rv0 = kInfinity, rv1 = -kInfinity, far = 0;
    for (size_t q = 0; q < n; ++q) {
      const ViewBox& rb = boxes[q];
      if (rb.empty) continue;
      if (q == o) {
        if (flat) continue;
      } else {
        if (rb.z1 <= c.z0) continue;  // entirely nearer to the light than the caster
        if (!windows_overlap(rb, su0, su1, sv0, sv1)) continue;
        if (light_side != 0) {
          bool beyond = false;
          for (int k = 0; k < 8 && !beyond; ++k) beyond = light_side * dot(bounds[q].corner(k) - p0, pn) < -tol;
          if (!beyond) continue;
        }
      }
      any = true;
      ru0 = std::min(ru0, rb.u0); ru1 = std::max(ru1, rb.u1);
      rv0 = std::min(rv0, rb.v0); rv1 = std::max(rv1, rb.v1);
      far = std::max(far, rb.z1);
    }
    if (!any) continue;
    float wu0 = std::max(su0, ru0), wu1 = std::min(su1, ru1);
    float wv0 = std::max(sv0, rv0), wv1 = std::min(sv1, rv1);
    if (!(wu0 < wu1) || !(wv0 < wv1)) continue;
    r.empty = false;
    r.u0 = std::min(r.u0, wu0); r.u1 = std::max(r.u1, wu1);
    r.v0 = std::min(r.v0, wv0); r.v1 = std::max(r.v1, wv1);
    r.near = std::min(r.near, c.z0);
    r.far = std::max(r.far, far);
  }
  if (r.empty) return ShadowRegion{};
  return r;
}

LightView reference_view(const LightAxes& a, const ShadowRegion& region, int resolution) {
  if (region.empty) throw Error("lam: reference_view of an empty shadow region");
  if (resolution < 4 || resolution > 16384) throw Error("lam: resolution {} must be in [4, 16384]", resolution);
  // Square texels; one texel of margin on each side.
  float wu = region.u1 - region.u0, wv = region.v1 - region.v0;
  float delta = std::max(wu, wv) / static_cast<float>(resolution - 2);
  int w = std::clamp(static_cast<int>(std::ceil(wu / delta)) + 2, 4, resolution);
  int h = std::clamp(static_cast<int>(std::ceil(wv / delta)) + 2, 4, resolution);
  float cu = 0.5f * (region.u0 + region.u1), cv = 0.5f * (region.v0 + region.v1);
  float u0 = cu - 0.5f * w * delta, u1 = cu + 0.5f * w * delta;
  float v0 = cv - 0.5f * h * delta, v1 = cv + 0.5f * h * delta;
  float near = region.near * (1 - 1e-3f), far = std::max(region.far * (1 + 1e-3f), near * 1.01f);
  // The window lives on the near plane.
  return LightView::frustum(a.eye, a.forward, a.up, u0 * near, u1 * near, v0 * near, v1 * near, near, far, w, h);
}

LightView sample_view(const LightAxes& a, const LightView& ref, Vec3f sample, int* offset_x, int* offset_y) {
  const float near = ref.near(), far = ref.far();
  const float delta = (ref.window_right() - ref.window_left()) / (near * ref.width());
  const float u0 = ref.window_left() / near, v1 = ref.window_top() / near;
  Vec3f d = sample - a.eye;
  float dx = dot(d, a.right), dy = dot(d, a.up);
  // A point at depth z and reference coordinate u appears at u - dx / z from the sample.
  float sx0 = std::min(-dx / near, -dx / far), sx1 = std::max(-dx / near, -dx / far);
  float sy0 = std::min(-dy / near, -dy / far), sy1 = std::max(-dy / near, -dy / far);
  int ox0 = static_cast<int>(std::floor(sx0 / delta)) - 1, ox1 = static_cast<int>(std::ceil(sx1 / delta)) + 1;
  int oy0 = static_cast<int>(std::floor(sy0 / delta)) - 1, oy1 = static_cast<int>(std::ceil(sy1 / delta)) + 1;
  int w = std::min(16384, ref.width() + ox1 - ox0), h = std::min(16384, ref.height() + oy1 - oy0);
  // Reference texel x = sample texel x + ox0 + dx / (z delta); rows grow downward and the
  // sample view's top edge lies oy1 texels above the reference's, so reference texel
  // y = sample texel y - oy1 - dy / (z delta).
  float su0 = u0 + ox0 * delta, sv1 = v1 + oy1 * delta;
  float su1 = su0 + w * delta, sv0 = sv1 - h * delta;
  *offset_x = ox0;
  *offset_y = -oy1;
  return LightView::frustum(sample, a.forward, a.up, su0 * near, su1 * near, sv0 * near, sv1 * near, near, far, w, h);
}

// ---------------------------------------------------------------------------------------
// Lookup.

namespace {

// The lookup in one texel's layers [l, e) (sorted by depth): the attenuation of the layer
// nearest to z within tol (>= 0); kOccluded if none matches but one lies in front of z;
// kUndefined if none lies at or in front of z.
constexpr float kOccluded = -1.0f, kUndefined = -2.0f;

inline float lookup(const Layer* l, const Layer* e, float z, float tol) {
  float best = tol, result = kUndefined;
  for (; l != e; ++l) {
    float d = std::abs(l->z - z);
    if (d <= best) {
      best = d;
      result = l->attenuation;
    } else if (l->z < z) {
      result = kOccluded;  // in front (a later match overrides it)
    } else {
      break;  // behind z beyond the best match: no later layer can be nearer
    }
  }
  return result;
}

}  // namespace

LookupClass AttenuationMap::classify(int x, int y, float z, float* attenuation) const {
  size_t i = static_cast<size_t>(y) * width_ + x;
  float r = lookup(layers_.data() + offsets_[i], layers_.data() + offsets_[i + 1], z, depth_tolerance(epsilon_, z));
  if (r >= 0) {
    *attenuation = r;
    return LookupClass::Match;
  }
  return r == kOccluded ? LookupClass::Occluded : LookupClass::Undefined;
}

namespace {

// One texel: the common single-layer case without the loop.
inline float lookup_texel(const Layer* layers, const uint32_t* offsets, size_t t, float z, float eps) {
  const uint32_t b = offsets[t], e = offsets[t + 1];
  const float tol = depth_tolerance(eps, z);
  if (e - b == 1) {
    const Layer& l = layers[b];
    const float d = l.z - z;
    return std::abs(d) <= tol ? l.attenuation : (d < 0 ? kOccluded : kUndefined);
  }
  return lookup(layers + b, layers + e, z, tol);
}

}  // namespace

template <bool kBilinear, bool kSlope>
inline float AttenuationMap::visibility_impl(Vec3f p, Vec3f n, uint64_t& texels) const {
  const float z = proj_[2][0] * p.x + proj_[2][1] * p.y + proj_[2][2] * p.z + proj_[2][3];
  if (!(z >= near_ && z <= far_)) return 1.0f;
  const float inv = 1.0f / z;
  const float x = (proj_[0][0] * p.x + proj_[0][1] * p.y + proj_[0][2] * p.z + proj_[0][3]) * inv;
  const float y = (proj_[1][0] * p.x + proj_[1][1] * p.y + proj_[1][2] * p.z + proj_[1][3]) * inv;
  if (!(x >= 0 && y >= 0 && x < static_cast<float>(width_) && y < static_cast<float>(height_))) return 1.0f;
  // p's surface as a plane in the reference view: linear depth on the ray through texel
  // point (X, Y) is nd / (nr X - nu Y + nf) (u = u0 + X delta, v = v1 - Y delta). The layers
  // hold depths at texel centres, so p's depth is carried to the same centres.
  float nd = 0, nr = 0, nu = 0, nf = 0, den_p = 0;
  bool plane = false;
  if constexpr (kSlope) {
    nd = dot(n, p - eye_);
    nr = dot(n, right_) * delta_;
    nu = dot(n, up_) * delta_;
    nf = dot(n, forward_) + dot(n, right_) * u0_ + dot(n, up_) * v1_;
    den_p = nr * x - nu * y + nf;
    plane = den_p != 0;  // false for n = 0 too
  }
  const float cap = 2 * kMaxSlope * z;
  // Depth of p's plane on the ray through the centre (cx, cy), clamped; p's own depth where
  // the plane turns edge-on in between.
  auto depth_at = [&](float cx, float cy) {
    if constexpr (!kSlope) return z;
    if (!plane) return z;
    float den = nr * cx - nu * cy + nf;
    if (!(den * den_p > 0)) return z;
    return std::clamp(nd / den, z - cap, z + cap);
  };
  const Layer* layers = layers_.data();
  const uint32_t* offsets = offsets_.data();
  if constexpr (!kBilinear) {
    int ix = std::min(static_cast<int>(x), width_ - 1), iy = std::min(static_cast<int>(y), height_ - 1);
    ++texels;
    float zt = depth_at(ix + 0.5f, iy + 0.5f);
    float r = lookup_texel(layers, offsets, static_cast<size_t>(iy) * width_ + ix, zt, epsilon_);
    return r >= 0 ? r : (r == kOccluded ? 0.0f : 1.0f);
  } else {
    // Bilinear over the 4 texel centres around p (percentage-closer style, agrawala2000
    // §6.1); texels that p's surface does not reach (kUndefined) drop out of the weights.
    const float fx = x - 0.5f, fy = y - 0.5f;  // >= -0.5
    const int x0 = static_cast<int>(fx + 1.0f) - 1, y0 = static_cast<int>(fy + 1.0f) - 1;
    const float wx = fx - static_cast<float>(x0), wy = fy - static_cast<float>(y0);
    float sum = 0, wsum = 0;
    auto texel = [&](int tx, int ty, float w) {
      if (tx < 0 || ty < 0 || tx >= width_ || ty >= height_) return;
      ++texels;
      const float zt = depth_at(tx + 0.5f, ty + 0.5f);
      const float r = lookup_texel(layers, offsets, static_cast<size_t>(ty) * width_ + tx, zt, epsilon_);
      if (r >= 0) {
        sum += w * r;
        wsum += w;
      } else if (r == kOccluded) {
        wsum += w;
      }
    };
    texel(x0, y0, (1 - wx) * (1 - wy));
    texel(x0 + 1, y0, wx * (1 - wy));
    texel(x0, y0 + 1, (1 - wx) * wy);
    texel(x0 + 1, y0 + 1, wx * wy);
    return wsum > 0 ? sum / wsum : 1.0f;
  }
}

namespace {
constexpr uint64_t kMapRecordMagic = 0x314d4454414d414cull;  // "LAMATDM1"
}  // namespace

void AttenuationMap::write(std::ostream& out) const {
  static_assert(std::is_trivially_copyable_v<LightView>);
  binary::write(out, kMapRecordMagic);
  binary::write_array(out, outline_);
  binary::write(out, light_center_);
  binary::write(out, light_normal_);
  binary::write(out, light_area_);
  binary::write(out, light_radius_);
  binary::write_array(out, std::vector<uint8_t>(solid_.begin(), solid_.end()));
  binary::write(out, width_);
  binary::write(out, height_);
  binary::write(out, samples_);
  binary::write(out, epsilon_);
  binary::write(out, view_);
  binary::write(out, proj_);
  binary::write(out, near_);
  binary::write(out, far_);
  binary::write(out, slope_);
  binary::write(out, eye_);
  binary::write(out, right_);
  binary::write(out, up_);
  binary::write(out, forward_);
  binary::write(out, u0_);
  binary::write(out, v1_);
  binary::write(out, delta_);
  binary::write_array(out, offsets_);
  binary::write_array(out, layers_);
  binary::write(out, kMapRecordMagic);
}

bool AttenuationMap::read(std::istream& in) {
  AttenuationMap m;
  uint64_t magic = 0, end_magic = 0;
  std::vector<uint8_t> solid;
  constexpr uint64_t kMaxElements = uint64_t{1} << 34;
  const bool ok =
      binary::read(in, magic) && magic == kMapRecordMagic && binary::read_array(in, m.outline_, kMaxOutline) &&
      binary::read(in, m.light_center_) && binary::read(in, m.light_normal_) && binary::read(in, m.light_area_) &&
      binary::read(in, m.light_radius_) && binary::read_array(in, solid, kMaxElements) &&
      binary::read(in, m.width_) && binary::read(in, m.height_) && binary::read(in, m.samples_) &&
      binary::read(in, m.epsilon_) && binary::read(in, m.view_) && binary::read(in, m.proj_) &&
      binary::read(in, m.near_) && binary::read(in, m.far_) && binary::read(in, m.slope_) &&
      binary::read(in, m.eye_) && binary::read(in, m.right_) && binary::read(in, m.up_) &&
      binary::read(in, m.forward_) && binary::read(in, m.u0_) && binary::read(in, m.v1_) &&
      binary::read(in, m.delta_) && binary::read_array(in, m.offsets_, kMaxElements) &&
      binary::read_array(in, m.layers_, kMaxElements) && binary::read(in, end_magic) && end_magic == kMapRecordMagic;
  if (!ok || m.width_ < 0 || m.height_ < 0) return false;
  // The lookups index offsets_ by texel and layers_ by offset: check they stay inside.
  if (m.width_ > 0) {
    const uint64_t texels = static_cast<uint64_t>(m.width_) * static_cast<uint64_t>(m.height_);
    if (m.offsets_.size() != texels + 1 || m.offsets_.front() != 0 || m.offsets_.back() != m.layers_.size())
      return false;
    for (size_t i = 0; i + 1 < m.offsets_.size(); ++i)
      if (m.offsets_[i] > m.offsets_[i + 1]) return false;
  }
  m.solid_.assign(solid.begin(), solid.end());
  *this = std::move(m);
  return true;
}

float AttenuationMap::front_fraction(Vec3f p, Vec3f n) const {
  if (outline_.empty() || !(length_squared(n) > 0)) return 1.0f;
  // Quick exits: the plane misses the light's bounding sphere (n is unit length).
  const float sc = dot(n, light_center_ - p);
  if (sc >= light_radius_) return 1.0f;
  if (sc <= -light_radius_) return 0.0f;
  const size_t m = outline_.size();
  float side[kMaxOutline];
  int front = 0;
  for (size_t i = 0; i < m; ++i) {
    side[i] = dot(n, outline_[i] - p);
    front += side[i] > 0;
  }
  if (front == static_cast<int>(m)) return 1.0f;
  if (front == 0) return 0.0f;
  // Area of the outline clipped to the front half-space (Sutherland-Hodgman, one plane),
  // as a fan around the light centre.
  float area = 0;
  Vec3f first{}, prev{};
  bool have = false;
  auto emit = [&](Vec3f v) {
    if (have) area += dot(light_normal_, cross(prev - light_center_, v - light_center_));
    else first = v;
    prev = v;
    have = true;
  };
  for (size_t i = 0; i < m; ++i) {
    size_t j = (i + 1) % m;
    if (side[i] > 0) emit(outline_[i]);
    if ((side[i] > 0) != (side[j] > 0)) emit(outline_[i] + (outline_[j] - outline_[i]) * (side[i] / (side[i] - side[j])));
  }
  area += dot(light_normal_, cross(prev - light_center_, first - light_center_));
  return std::clamp(0.5f * area / light_area_, 0.0f, 1.0f);
}

float AttenuationMap::visibility(Vec3f p, Vec3f n, Filter filter, uint64_t* texels) const {
  if (empty()) return 1.0f;
  uint64_t t = 0;
  float v = filter == Filter::Bilinear ? (slope_ ? visibility_impl<true, true>(p, n, t) : visibility_impl<true, false>(p, n, t))
                                       : (slope_ ? visibility_impl<false, true>(p, n, t) : visibility_impl<false, false>(p, n, t));
  if (texels) *texels += t;
  return v;
}

template <bool kBilinear, bool kSlope>
void AttenuationMap::visibility_batch(std::span<const ViewSample> samples, std::span<float> out,
                                      uint64_t* texels) const {
  uint64_t t = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const ViewSample& s = samples[i];
    const float v = visibility_impl<kBilinear, kSlope>(s.p, s.ng, t);
    out[i] = v > 0 && s.object < solid_.size() && solid_[s.object] ? std::min(v, front_fraction(s.p, s.ng)) : v;
  }
  if (texels) *texels += t;
}

void AttenuationMap::visibility(std::span<const ViewSample> samples, std::span<float> out, Filter filter,
                                uint64_t* texels) const {
  if (empty()) {
    for (size_t i = 0; i < samples.size(); ++i) {
      const ViewSample& s = samples[i];
      out[i] = s.object < solid_.size() && solid_[s.object] ? front_fraction(s.p, s.ng) : 1.0f;
    }
    return;
  }
  if (filter == Filter::Bilinear)
    slope_ ? visibility_batch<true, true>(samples, out, texels) : visibility_batch<true, false>(samples, out, texels);
  else
    slope_ ? visibility_batch<false, true>(samples, out, texels) : visibility_batch<false, false>(samples, out, texels);
}

// ---------------------------------------------------------------------------------------
// Precomputation.

namespace {

// A layer while building: running mean depth, light samples counted, last sample counted.
struct BuildLayer {
  float z;
  uint16_t count;
  uint16_t stamp;  // 1 + index of the last light sample that counted this layer
};

// A warped depth-map pixel: the texel (ix, iy) whose centre is the top-left of the 4 it
// splats into, and its depth.
// splats into, the depth extrapolated to that texel's centre along the surface's local
// plane, and the plane's depth gradient per reference texel (x, y).
struct Splat {
  int16_t ix, iy;
  float z00, gx, gy;
};

// Depth gradient along one image axis at a pixel from its two neighbours (zm at -1, zp at
// +1): central where both lie on the same surface, else the one-sided difference that does.
inline float axis_gradient(float zm, float z, float zp) {
  const float jump = 4 * kMaxSlope * z;
  bool okm = std::abs(zm - z) <= jump, okp = std::abs(zp - z) <= jump;  // false for +inf
  float dm = z - zm, dp = zp - z;
  if (okm && okp) {
    // A crease or a small step: the gentler side.
    if (std::abs(dm - dp) > 0.5f * (std::abs(dm) + std::abs(dp)) + 1e-6f * z)
      return std::abs(dm) < std::abs(dp) ? dm : dp;
    return 0.5f * (dm + dp);
  }
  if (okm) return dm;
  if (okp) return dp;
  return 0.0f;
}

constexpr int kBandRows = 8;   // rows of the reference view one insertion task owns
constexpr int kChunkRows = 8;  // source rows per warp task

}  // namespace

class Builder {
 public:
  static AttenuationMap build(RasterTriangleView tris, const AreaLight& light, const ShadowRegion& region,
                              std::span<const Vec2f> samples, const BuildOptions& opt, BuildStats* st);
};

AttenuationMap Builder::build(RasterTriangleView tris, const AreaLight& light, const ShadowRegion& region,
                              std::span<const Vec2f> samples, const BuildOptions& opt, BuildStats* st) {
  if (samples.empty()) throw Error("lam: no light samples");
  if (samples.size() > 65535) throw Error("lam: at most 65535 light samples (got {})", samples.size());
  if (opt.max_layers < 1 || opt.max_layers > 255) throw Error("lam: max_layers {} must be in [1, 255]", opt.max_layers);
  if (!(opt.epsilon >= 0)) throw Error("lam: epsilon {} must be >= 0", opt.epsilon);
  BuildStats local;
  BuildStats& s = st ? *st : local;
  s = BuildStats{};
  AttenuationMap map;
  map.samples_ = static_cast<int>(samples.size());
  map.epsilon_ = opt.epsilon;
  map.solid_ = opt.solid_objects;
  {
    // The light as the LDI's samples see it: the polygon its samples lie in.
    map.outline_ = light.outline(AttenuationMap::kMaxOutline);
    map.light_center_ = light.center;
    map.light_normal_ = normalize(light.frame.n);
    float area = 0, radius = 0;
    for (size_t i = 0; i < map.outline_.size(); ++i) {
      const Vec3f a = map.outline_[i] - light.center, b = map.outline_[(i + 1) % map.outline_.size()] - light.center;
      area += dot(map.light_normal_, cross(a, b));
      radius = std::max(radius, length(a));
    }
    map.light_area_ = std::max(0.5f * std::abs(area), 1e-30f);
    if (area < 0) map.light_normal_ = -map.light_normal_;  // counter-clockwise around the normal
    map.light_radius_ = radius * (1 + 1e-5f);
  }
  if (region.empty) return map;

  const LightAxes axes = light_axes(light);
  map.view_ = reference_view(axes, region, opt.resolution);
  const LightView& ref = map.view_;
  const int W = ref.width(), H = ref.height();
  const size_t texels = static_cast<size_t>(W) * H;
  const int K = opt.max_layers;
  const float delta = (ref.window_right() - ref.window_left()) / (ref.near() * W);
  const float eps = opt.epsilon;
  const bool slope = opt.slope;
  map.slope_ = slope;
  map.delta_ = delta;
  map.u0_ = ref.window_left() / ref.near();
  map.v1_ = ref.window_top() / ref.near();
  map.eye_ = axes.eye;
  map.right_ = axes.right;
  map.up_ = axes.up;
  map.forward_ = axes.forward;
  map.width_ = W;
  map.height_ = H;
  map.near_ = ref.near();
  map.far_ = ref.far();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) map.proj_[r][c] = ref.texel_projection().m[r][c];

  std::vector<uint8_t> counts(texels, 0);
  // Uninitialised: slot i of a texel is read only once counts says it exists, so the
  // planes of deep slots are never touched (nor committed) unless some texel needs them.
  auto layers = std::make_unique_for_overwrite<BuildLayer[]>(texels * K);
  const int bands = (H + kBandRows - 1) / kBandRows;
  // Per band: layers created and texels that became non-empty (depth complexity per sample).
  std::vector<size_t> band_layers(bands, 0), band_nonempty(band_layers.size(), 0), band_dropped(bands, 0);
  std::vector<size_t> band_splats(bands, 0);
  size_t total_layers = 0, total_nonempty = 0;
  s.depth_complexity.reserve(samples.size());

  // 1 / k for the running mean of a layer's depth.
  std::vector<float> inv_count(samples.size() + 1, 0.0f);
  for (size_t k = 1; k < inv_count.size(); ++k) inv_count[k] = 1.0f / static_cast<float>(k);
  Rasterizer raster;
  DepthMap dm;
  std::vector<Splat> splats;
  std::vector<uint32_t> chunk_band_count;
  std::vector<Splat> binned;
  size_t peak_scratch = 0;
  for (size_t si = 0; si < samples.size(); ++si) {
    const Vec3f q = light.sample_area(samples[si]);
    int ox = 0, oy = 0;
    const LightView view = sample_view(axes, ref, q, &ox, &oy);
    Timer t_raster;
    raster.depth_map(tris, view, RasterFilter{}, &dm);
    s.raster_ms += t_raster.elapsed_ms();
    s.sample_texels += static_cast<size_t>(view.width()) * view.height();

    // Warp (eq. 3) every covered pixel; bucket the splats by the band(s) of reference rows
    // they touch (counting sort: fixed chunk order keeps the result thread-independent).
    Timer t_warp;
    const Vec3f d = q - axes.eye;
    const float bx = dot(d, axes.right) / delta, by = dot(d, axes.up) / delta;
    const int sw = view.width(), sh = view.height();
    const int chunks = (sh + kChunkRows - 1) / kChunkRows;
    splats.resize(static_cast<size_t>(sw) * sh);
    chunk_band_count.assign(static_cast<size_t>(chunks) * bands, 0);
    std::vector<uint32_t> chunk_splats(chunks, 0);
    parallel_for(chunks, 1, [&](size_t c0, size_t c1) {
      for (size_t c = c0; c < c1; ++c) {
        uint32_t* cnt = chunk_band_count.data() + c * bands;
        int y_begin = static_cast<int>(c) * kChunkRows, y_end = std::min(sh, y_begin + kChunkRows);
        Splat* out = splats.data() + static_cast<size_t>(y_begin) * sw;
        uint32_t m = 0;
        for (int y = y_begin; y < y_end; ++y) {
          const float* zr = dm.z.data() + static_cast<size_t>(y) * sw;
          for (int x = 0; x < sw; ++x) {
            float z = zr[x];
            if (!(z < kInfinity)) continue;
            float inv = 1.0f / z;
            // Reference texel-space position minus 0.5: the top-left splat centre.
            float fx = (x + 0.5f) + ox + bx * inv - 0.5f;
            float fy = (y + 0.5f) + oy - by * inv - 0.5f;
            if (!(fx >= -1.0f && fy >= -1.0f && fx < static_cast<float>(W) && fy < static_cast<float>(H))) continue;
            const int ix = static_cast<int>(fx + 1.0f) - 1, iy = static_cast<int>(fy + 1.0f) - 1;  // floor
            float gx = 0, gy = 0, z00 = z;
            if (slope) {
              // The surface's depth gradient in the sample view (per texel), carried through
              // the warp's Jacobian J = I + a g^T (a = (-bx, by) / z^2): per reference texel
              // it is g / (1 + g.a).
              float sgx = axis_gradient(x > 0 ? zr[x - 1] : kInfinity, z, x + 1 < sw ? zr[x + 1] : kInfinity);
              float sgy = axis_gradient(y > 0 ? zr[x - sw] : kInfinity, z, y + 1 < sh ? zr[x + sw] : kInfinity);
              const float rden = 1.0f / std::max(1.0f + (-bx * sgx + by * sgy) * inv * inv, 0.2f);
              const float cap = kMaxSlope * z;
              gx = std::clamp(sgx * rden, -cap, cap);
              gy = std::clamp(sgy * rden, -cap, cap);
              z00 = z - gx * (fx - ix) - gy * (fy - iy);
            }
            out[m++] = {static_cast<int16_t>(ix), static_cast<int16_t>(iy), z00, gx, gy};
            int b0 = std::max(iy, 0) / kBandRows, b1 = std::min(iy + 1, H - 1) / kBandRows;
            cnt[b0]++;
            if (b1 != b0) cnt[b1]++;
          }
        }
        chunk_splats[c] = m;
      }
    });
    // Offsets band-major, chunk-minor.
    std::vector<size_t> offs(static_cast<size_t>(chunks) * bands + 1, 0);
    {
      size_t acc = 0;
      for (int b = 0; b < bands; ++b)
        for (int c = 0; c < chunks; ++c) {
          offs[static_cast<size_t>(b) * chunks + c] = acc;
          acc += chunk_band_count[static_cast<size_t>(c) * bands + b];
        }
      offs.back() = acc;
      binned.resize(acc);
    }
    parallel_for(chunks, 1, [&](size_t c0, size_t c1) {
      std::vector<size_t> pos(bands);
      for (size_t c = c0; c < c1; ++c) {
        for (int b = 0; b < bands; ++b) pos[b] = offs[static_cast<size_t>(b) * chunks + c];
        const size_t base = static_cast<size_t>(c) * kChunkRows * sw;
        for (uint32_t k = 0; k < chunk_splats[c]; ++k) {
          const Splat& sp = splats[base + k];
          int b0 = std::max<int>(sp.iy, 0) / kBandRows, b1 = std::min<int>(sp.iy + 1, H - 1) / kBandRows;
          binned[pos[b0]++] = sp;
          if (b1 != b0) binned[pos[b1]++] = sp;
        }
      }
    });
    peak_scratch = std::max(peak_scratch, (splats.size() + binned.size()) * sizeof(Splat) +
                                              dm.z.size() * (3 * sizeof(float) + sizeof(uint32_t)));
    s.warp_ms += t_warp.elapsed_ms();

    // Insert (agrawala2000 §4, line 6): each band owns its rows, so no two threads touch a
    // texel; within a band the splats come in source scan order.
    Timer t_insert;
    const uint16_t stamp = static_cast<uint16_t>(si + 1);
    parallel_for(bands, 1, [&](size_t b0, size_t b1) {
      for (size_t b = b0; b < b1; ++b) {
        const int row0 = static_cast<int>(b) * kBandRows, row1 = std::min(H, row0 + kBandRows);
        size_t new_layers = 0, new_nonempty = 0, dropped = 0, n_splats = 0;
        auto insert = [&](int tx, int ty, float z) {
          size_t t = static_cast<size_t>(ty) * W + tx;
          // Layer-major storage: slot i of texel t at i * texels + t, so the first layers
          // (almost every texel has one or two) are dense.
          BuildLayer* L = layers.get() + t;
          int n = counts[t];
          const float tol = depth_tolerance(eps, z);
          int best = -1;
          float bestd = tol;
          for (int i = 0; i < n; ++i) {
            float dd = std::abs(L[i * texels].z - z);
            if (dd <= bestd) {
              bestd = dd;
              best = i;
            }
          }
          ++n_splats;
          if (best >= 0) {
            BuildLayer& l = L[best * texels];
            if (l.stamp != stamp) {  // at most once per light sample
              l.stamp = stamp;
              l.count++;
              l.z += (z - l.z) * inv_count[l.count];
            }
          } else if (n < K) {
            L[n * texels] = {z, 1, stamp};
            counts[t] = static_cast<uint8_t>(n + 1);
            ++new_layers;
            if (n == 0) ++new_nonempty;
          } else {
            ++dropped;
          }
        };
        for (size_t k = offs[b * chunks]; k < offs[(b + 1) * chunks]; ++k) {
          const Splat& sp = binned[k];
          for (int j = 0; j < 2; ++j) {
            int ty = sp.iy + j;
            if (ty < row0 || ty >= row1) continue;
            float zr = j ? sp.z00 + sp.gy : sp.z00;
            if (sp.ix >= 0) insert(sp.ix, ty, zr);
            if (sp.ix + 1 < W) insert(sp.ix + 1, ty, zr + sp.gx);
          }
        }
        band_layers[b] = new_layers;
        band_nonempty[b] = new_nonempty;
        band_dropped[b] += dropped;
        band_splats[b] += n_splats;
      }
    });
    for (int b = 0; b < bands; ++b) {
      total_layers += band_layers[b];
      total_nonempty += band_nonempty[b];
    }
    s.depth_complexity.emplace_back(static_cast<int>(si + 1),
                                    total_nonempty ? static_cast<double>(total_layers) / total_nonempty : 0.0);
    s.insert_ms += t_insert.elapsed_ms();
  }
  for (int b = 0; b < bands; ++b) {
    s.dropped += band_dropped[b];
    s.splats += band_splats[b];
  }

  // Process Attenuation Maps (line 7): attenuation = count / N; layers sorted by depth in
  // flat, texel-major storage.
  Timer t_fin;
  map.offsets_.assign(texels + 1, 0);
  uint32_t acc = 0;
  int max_depth = 0;
  for (size_t t = 0; t < texels; ++t) {
    map.offsets_[t] = acc;
    acc += counts[t];
    max_depth = std::max<int>(max_depth, counts[t]);
  }
  map.offsets_[texels] = acc;
  map.layers_.resize(acc);
  const float inv_n = 1.0f / static_cast<float>(samples.size());
  parallel_for(H, 8, [&](size_t y0, size_t y1) {
    for (size_t y = y0; y < y1; ++y)
      for (int x = 0; x < W; ++x) {
        size_t t = y * W + x;
        BuildLayer L[256];
        int n = counts[t];
        for (int i = 0; i < n; ++i) L[i] = layers[i * texels + t];
        std::sort(L, L + n, [](const BuildLayer& a, const BuildLayer& b) { return a.z < b.z; });
        Layer* out = map.layers_.data() + map.offsets_[t];
        for (int i = 0; i < n; ++i) out[i] = {L[i].z, std::min(1.0f, L[i].count * inv_n)};
      }
  });
  s.finalize_ms = t_fin.elapsed_ms();
  s.nonempty_texels = total_nonempty;
  s.layers = total_layers;
  s.max_depth = max_depth;
  s.peak_bytes = counts.size() + texels * (max_depth * sizeof(BuildLayer)) + peak_scratch + map.memory_bytes();
  return map;
}

int sample_view_side_bound(int resolution) {
  // The disparity of a light sample over the casters' depth range is at most the light's
  // half-extent over the nearest depth, which fit_shadow_region already added on each side
  // of the window: a sample view is at most about 1.5 times the LDI's side; 2 with margin,
  // within sample_view's own cap.
  return std::min(16384, 2 * resolution);
}

uint64_t build_bytes(int resolution, int max_layers) {
  const uint64_t texels = static_cast<uint64_t>(resolution) * static_cast<uint64_t>(resolution);
  const uint64_t slots = texels * static_cast<uint64_t>(max_layers);
  const int side = sample_view_side_bound(resolution);
  const uint64_t sample_texels = static_cast<uint64_t>(side) * static_cast<uint64_t>(side);
  // Splats: one per covered pixel, binned into up to two bands each; the per-(chunk, band)
  // counts and offsets.
  const uint64_t chunks = (side + kChunkRows - 1) / kChunkRows, bands = (resolution + kBandRows - 1) / kBandRows;
  const uint64_t sample_view = DepthMap::bytes(side, side) + 3 * sample_texels * sizeof(Splat) +
                               chunks * bands * (sizeof(uint32_t) + sizeof(size_t));
  const uint64_t map = (texels + 1) * sizeof(uint32_t) + slots * sizeof(Layer);
  return texels * sizeof(uint8_t) + slots * sizeof(BuildLayer) + sample_view + map;
}

AttenuationMap build_attenuation_map(RasterTriangleView triangles, const AreaLight& light,
                                     const ShadowRegion& region, std::span<const Vec2f> light_samples,
                                     const BuildOptions& options, BuildStats* stats) {
  return Builder::build(triangles, light, region, light_samples, options, stats);
}

}  // namespace penumbra::lam
