#include "penumbra/shadow/alias_free/influence_region.h"

#include <algorithm>
#include <cmath>

namespace penumbra::afsm {
namespace {

// A projection through a vertex farther than this (far-plane distance over the vertex's
// distance in front of the light point) is treated as unbounded: the region would span
// thousands of images anyway, and float coordinates lose the texel.
constexpr float kMaxStretch = 1e4f;

float cross2(Vec2f o, Vec2f a, Vec2f b) { return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x); }

}  // namespace

int typical_region_vertices(const AreaLight* light) {
  const int polygon = !light ? 8 : light->shape == LightShape::Rect ? 4 : light->shape == LightShape::Disk ? 8 : 6;
  return polygon + 3;
}

InfluenceRegions::InfluenceRegions(const AreaLight& light, const LightView& view, float far_depth)
    : light_(light), view_(view), far_(far_depth) {
  if (light.shape == LightShape::Rect || light.shape == LightShape::Disk) {
    outline_ = light.outline(8);
    for (const Vec3f& q : outline_) {
      float h[4];
      view.texel_homogeneous(q, h);
      outline_texel_.push_back({h[0], h[1], h[3], dot(q - light.center, view.forward())});
    }
  }
}

bool InfluenceRegions::project(std::span<const Vec3f> v, std::vector<Vec2f>* out) const {
  out->clear();
  const Vec3f c = light_.center, axis = view_.forward();
  Vec3f hexagon[6];
  if (!outline_texel_.empty()) {
    // A rect or disk: the same polygon for every vertex (the loop below, one transform a vertex).
    for (const Vec3f& x : v) {
      float hv[4];
      view_.texel_homogeneous(x, hv);
      const float zv = dot(x - c, axis);
      for (const std::array<float, 4>& q : outline_texel_) {
        const float ahead = zv - q[3], reach = far_ - q[3];
        if (!(ahead > 0) || !(reach < kMaxStretch * ahead)) return false;
        const float t = reach / ahead;
        const float w = q[2] + (hv[3] - q[2]) * t;
        const Vec2f texel{(q[0] + (hv[0] - q[0]) * t) / w, (q[1] + (hv[1] - q[1]) * t) / w};
        if (!std::isfinite(texel.x) || !std::isfinite(texel.y)) return false;
        out->push_back(texel);
      }
    }
    return true;
  }
  for (size_t k = 0; k < v.size(); ++k) {
    std::span<const Vec3f> polygon = outline_;
    if (light_.shape == LightShape::Sphere || light_.shape == LightShape::Ellipsoid) {
      // The silhouette of the ball seen from v: a circle of radius r' around c + u R^2 / d
      // in the plane perpendicular to u; its circumscribed hexagon. An ellipsoid is scaled to
      // the unit sphere first (§4.1, "a virtual scaling of the entire scene"): the hexagon is
      // built around the unit ball seen from A^-1(v) and mapped back with A. The cone from
      // A^-1(v) over it holds the unit ball, so its image, the cone from v over the mapped
      // hexagon, holds the ellipsoid; and the projection through v onto the far plane below
      // commutes with A (lines to lines, planes to planes, parallel planes stay parallel), so
      // the region is A of the one computed in the scaled scene.
      const bool ellipsoid = light_.shape == LightShape::Ellipsoid;
      const Vec3f cc = ellipsoid ? Vec3f(0.0f) : c;
      const Vec3f to_v = (ellipsoid ? light_.to_unit_sphere(v[k]) : v[k]) - cc;
      const float d = length(to_v), r = ellipsoid ? 1.0f : light_.radius;
      if (!(d > r * 1.001f)) return false;
      const Vec3f u = to_v / d;
      const Vec3f m = cc + u * (r * r / d);
      const float rho = r * std::sqrt(std::max(0.0f, 1 - (r * r) / (d * d))) / std::cos(kPi / 6);
      Vec3f a, b;
      coordinate_system(u, &a, &b);
      for (int j = 0; j < 6; ++j) {
        const float phi = j * (kPi / 3);
        hexagon[j] = m + (a * std::cos(phi) + b * std::sin(phi)) * rho;
        if (ellipsoid) hexagon[j] = light_.from_unit_sphere(hexagon[j]);
      }
      polygon = std::span<const Vec3f>(hexagon, 6);
    }
    const float zv = dot(v[k] - c, axis);
    for (const Vec3f& q : polygon) {
      const float zq = dot(q - c, axis);
      const float ahead = zv - zq, reach = far_ - zq;
      if (!(ahead > 0) || !(reach < kMaxStretch * ahead)) return false;
      const Vec3f f = q + (v[k] - q) * (reach / ahead);
      const Vec3f t = view_.to_texel(f);
      if (!std::isfinite(t.x) || !std::isfinite(t.y)) return false;
      out->push_back({t.x, t.y});
    }
  }
  return true;
}

void convex_hull(std::vector<Vec2f>* points) {
  std::vector<Vec2f>& p = *points;
  if (p.size() < 3) return;
  std::sort(p.begin(), p.end(), [](Vec2f a, Vec2f b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  // The chain in a buffer on the stack for the usual regions (3 x 8 points at most), so that
  // the millions of regions of a wide scene allocate nothing; copied back into p's storage.
  constexpr size_t kOnStack = 64;
  Vec2f on_stack[kOnStack];
  std::vector<Vec2f> on_heap;
  if (2 * p.size() > kOnStack) on_heap.resize(2 * p.size());
  Vec2f* hull = on_heap.empty() ? on_stack : on_heap.data();
  size_t k = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross2(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
    hull[k++] = p[i];
  }
  for (size_t i = p.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && cross2(hull[k - 2], hull[k - 1], p[i]) <= 0) --k;
    hull[k++] = p[i];
  }
  p.assign(hull, hull + (k > 1 ? k - 1 : k));
}

}  // namespace penumbra::afsm
