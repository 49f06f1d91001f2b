#include "penumbra/raster/shadow_view.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra {

ShadowViewFrame shadow_view_frame(Vec3f eye, Vec3f dir, Vec3f up, const Bounds3f& casters,
                                  std::span<const Vec3f> receivers, const ShadowViewFit& fit) {
  if (fit.resolution < 1 || fit.resolution > 16384)
    throw Error("fit_shadow_view: resolution {} must be between 1 and 16384", fit.resolution);
  if (!(fit.max_fov > 0) || !(fit.max_fov < 180))
    throw Error("fit_shadow_view: max_fov {} must be in (0, 180) degrees", fit.max_fov);
  // The view axes (LightView owns the convention).
  const LightView axes = LightView::perspective(eye, dir, up, 90.0f, 1, 1, 1.0f, 2.0f);
  float min_near = fit.min_near;
  if (!(min_near > 0)) {
    Bounds3f all = casters;
    if (all.empty())
      for (Vec3f p : receivers) all.extend(p);
    min_near = all.empty() ? 1e-6f : 1e-4f * std::max(length(all.diagonal()), 1e-6f);
  }
  ShadowViewFrame f{dir, up, {}};
  f.axes.eye = eye;
  f.axes.min_near = min_near;
  f.axes.right = axes.right();
  f.axes.up = axes.up();
  f.axes.forward = axes.forward();
  return f;
}

void ShadowViewRange::add(const ShadowViewRange& o) {
  x0 = std::min(x0, o.x0); x1 = std::max(x1, o.x1); y0 = std::min(y0, o.y0);
  y1 = std::max(y1, o.y1); z0 = std::min(z0, o.z0); z1 = std::max(z1, o.z1);
}

void ShadowViewRange::add(float x, float y, float z) {
  x0 = std::min(x0, x); x1 = std::max(x1, x);
  y0 = std::min(y0, y); y1 = std::max(y1, y);
  z0 = std::min(z0, z); z1 = std::max(z1, z);
}

ShadowViewRange reduce_receivers(const ShadowViewFrame& frame, std::span<const Vec3f> receivers) {
  // Extents of x/z and y/z over the receivers in front, and their depth range.
  const size_t chunk = 16384;
  std::vector<ShadowViewRange> parts((receivers.size() + chunk - 1) / chunk);
  parallel_for(parts.size(), 1, [&](size_t b, size_t e) {
    for (size_t c = b; c < e; ++c) {
      ShadowViewRange r;
      for (size_t k = c * chunk; k < std::min(receivers.size(), (c + 1) * chunk); ++k) {
        float x, y, z;
        if (shader::shadow_view_project(frame.axes, receivers[k], x, y, z)) r.add(x, y, z);
      }
      parts[c] = r;
    }
  });
  ShadowViewRange r;
  for (const ShadowViewRange& p : parts) r.add(p);
  return r;
}

LightView fit_shadow_view(Vec3f eye, Vec3f dir, Vec3f up, std::span<const Vec3f> receivers,
                          const Bounds3f& casters, const ShadowViewFit& fit) {
  const ShadowViewFrame frame = shadow_view_frame(eye, dir, up, casters, receivers, fit);
  return build_shadow_view(frame, reduce_receivers(frame, receivers), casters, fit);
}

LightView build_shadow_view(const ShadowViewFrame& frame, const ShadowViewRange& range, const Bounds3f& casters,
                            const ShadowViewFit& fit) {
  ShadowViewRange r = range;
  const Vec3f eye = frame.axes.eye, fwd = frame.axes.forward;
  const float min_near = frame.axes.min_near;
  if (!(r.z1 >= r.z0)) throw Error("fit_shadow_view: no receiver lies in front of the eye");
  // The cap keeps grazing receivers from taking the texels of the rest. Where every receiver
  // lies beyond it (a street seen from far down its length under a high light: all its points
  // 70-85 degrees off the light's axis) there is no rest: the window then holds them, up to
  // kWidestFov (before, the shadow-map family stopped with an error and the other fits counted
  // every receiver lit).
  auto capped = [&](float max_fov) {
    const float cap = std::tan(radians(max_fov) * 0.5f);
    ShadowViewRange c = range;
    c.x0 = std::max(c.x0, -cap); c.x1 = std::min(c.x1, cap);
    c.y0 = std::max(c.y0, -cap); c.y1 = std::min(c.y1, cap);
    return c;
  };
  auto empty = [](const ShadowViewRange& c) { return !(c.x1 >= c.x0) || !(c.y1 >= c.y0); };
  r = capped(fit.max_fov);
  // Beyond the cap, the receivers some caster can shadow (fit.reach): they would count lit.
  ShadowViewRange reach = capped(kWidestFov);
  reach.x0 = std::max(reach.x0, fit.reach_x0); reach.x1 = std::min(reach.x1, fit.reach_x1);
  reach.y0 = std::max(reach.y0, fit.reach_y0); reach.y1 = std::min(reach.y1, fit.reach_y1);
  if (!empty(reach)) {
    if (empty(r)) {
      r = reach;
    } else {
      r.x0 = std::min(r.x0, reach.x0); r.x1 = std::max(r.x1, reach.x1);
      r.y0 = std::min(r.y0, reach.y0); r.y1 = std::max(r.y1, reach.y1);
    }
  }
  if (empty(r)) r = capped(kWidestFov);
  if (empty(r))
    throw Error("fit_shadow_view: every receiver lies outside the {}-degree field of view", kWidestFov);
  // A little slack so points on the boundary land inside the image, and a minimum size.
  float px = std::max(1e-6f, (r.x1 - r.x0) * 1e-4f), py = std::max(1e-6f, (r.y1 - r.y0) * 1e-4f);
  float l = r.x0 - px, rr = r.x1 + px, b = r.y0 - py, t = r.y1 + py;
  // Near before every caster (never behind min_near, never beyond the receivers); far just
  // beyond the farthest receiver.
  float near = r.z0;
  if (!casters.empty()) {
    float zmin = kInfinity;
    for (int i = 0; i < 8; ++i) zmin = std::min(zmin, dot(casters.corner(i) - eye, fwd));
    near = std::min(near, zmin);
  }
  near = std::max(min_near, near * (1 - 1e-5f));
  float far = std::max(r.z1 * (1 + 1e-5f), near * (1 + 1e-4f));
  // Square texels: the longer side gets `resolution` texels, the shorter side is widened
  // (symmetrically) to a whole number of texels.
  float w = rr - l, h = t - b;
  int width, height;
  if (w >= h) {
    width = fit.resolution;
    height = std::clamp(static_cast<int>(std::ceil(fit.resolution * h / w - 1e-4f)), 1, fit.resolution);
    float grow = std::max(0.0f, (w * height / width - h) * 0.5f);
    b -= grow;
    t += grow;
  } else {
    height = fit.resolution;
    width = std::clamp(static_cast<int>(std::ceil(fit.resolution * w / h - 1e-4f)), 1, fit.resolution);
    float grow = std::max(0.0f, (h * width / height - w) * 0.5f);
    l -= grow;
    rr += grow;
  }
  return LightView::frustum(eye, frame.dir, frame.up, l * near, rr * near, b * near, t * near, near, far, width,
                           height);
}

}  // namespace penumbra
