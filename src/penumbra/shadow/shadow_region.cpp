#include "penumbra/shadow/shadow_region.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "penumbra/raster/light_view.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

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
    // The objects O shadows within the window [u0, u1] x [v0, v1]: their windows' union and
    // their farthest depth (any = false: none).
    struct Receivers {
      bool any = false;
      float u0 = kInfinity, u1 = -kInfinity, v0 = kInfinity, v1 = -kInfinity, far = 0;
    };
    auto receivers = [&](float u0, float u1, float v0, float v1) {
      Receivers rs;
      for (size_t q = 0; q < n; ++q) {
        const ViewBox& rb = boxes[q];
        if (rb.empty) continue;
        if (q == o) {
          if (flat) continue;
        } else {
          if (rb.z1 <= c.z0) continue;  // entirely nearer to the light than the caster
          if (!windows_overlap(rb, u0, u1, v0, v1)) continue;
          if (light_side != 0) {
            bool beyond = false;
            for (int k = 0; k < 8 && !beyond; ++k) beyond = light_side * dot(bounds[q].corner(k) - p0, pn) < -tol;
            if (!beyond) continue;
          }
        }
        rs.any = true;
        rs.u0 = std::min(rs.u0, rb.u0); rs.u1 = std::max(rs.u1, rb.u1);
        rs.v0 = std::min(rs.v0, rb.v0); rs.v1 = std::max(rs.v1, rb.v1);
        rs.far = std::max(rs.far, rb.z1);
      }
      return rs;
    };
    // Where the shadow volume reaches beyond the cap onto something it can shadow, the region is
    // cut there (cap_tan): the display traces the points beyond it (lam_beyond_cap).
    const float uu0 = c.u0 - gu, uu1 = c.u1 + gu, uv0 = c.v0 - gv, uv1 = c.v1 + gv;
    if (r.cap_tan == 0 && (uu0 < -max_tan || uu1 > max_tan || uv0 < -max_tan || uv1 > max_tan)) {
      const Receivers all = receivers(uu0, uu1, uv0, uv1);
      const float au0 = std::max(uu0, all.u0), au1 = std::min(uu1, all.u1);
      const float av0 = std::max(uv0, all.v0), av1 = std::min(uv1, all.v1);
      if (all.any && au0 <= au1 && av0 <= av1 && (au0 < -max_tan || au1 > max_tan || av0 < -max_tan || av1 > max_tan))
        r.cap_tan = max_tan;
    }
    if (!(su0 < su1) || !(sv0 < sv1)) continue;
    const Receivers rs = receivers(su0, su1, sv0, sv1);
    if (!rs.any) continue;
    {
      // Seen from a point of the light (at most the light's half-extent off the centre), a point
      // of the caster at depth z lies within the cap where its lateral offset plus that is at most
      // max_tan z: beyond it only nearer than `need`.
      float lateral = 0;
      for (int k = 0; k < 8; ++k) {
        const Vec3f d = bounds[o].corner(k) - a.eye;
        lateral = std::max({lateral, std::abs(dot(d, a.right)), std::abs(dot(d, a.up))});
      }
      const float need = (lateral + std::max(ex, ey)) / max_tan;
      if (need > c.z0) r.light_field = std::max(r.light_field, std::min(c.z1, need));
    }
    const float ru0 = rs.u0, ru1 = rs.u1, rv0 = rs.v0, rv1 = rs.v1, far = rs.far;
    float wu0 = std::max(su0, ru0), wu1 = std::min(su1, ru1);
    float wv0 = std::max(sv0, rv0), wv1 = std::min(sv1, rv1);
    if (!(wu0 < wu1) || !(wv0 < wv1)) continue;
    r.empty = false;
    r.u0 = std::min(r.u0, wu0); r.u1 = std::max(r.u1, wu1);
    r.v0 = std::min(r.v0, wv0); r.v1 = std::max(r.v1, wv1);
    r.near = std::min(r.near, c.z0);
    r.far = std::max(r.far, far);
  }
  if (r.empty) {
    ShadowRegion none;
    none.cap_tan = r.cap_tan;
    return none;
  }
  return r;
}

}  // namespace penumbra
