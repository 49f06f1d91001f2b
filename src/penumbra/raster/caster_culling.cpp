#include "penumbra/raster/caster_culling.h"

#include <array>

#include "penumbra/core/error.h"

namespace penumbra {

bool box_outside_view(const Bounds3f& box, const LightView& view) {
  if (box.empty()) return true;
  // The corners in view space: x right, y up, z the linear depth along forward.
  std::array<Vec3f, 8> c;
  for (int i = 0; i < 8; ++i) {
    const Vec3f p{(i & 1) ? box.hi.x : box.lo.x, (i & 2) ? box.hi.y : box.lo.y, (i & 4) ? box.hi.z : box.lo.z};
    const Vec3f d = p - view.eye();
    c[i] = {dot(d, view.right()), dot(d, view.up()), dot(d, view.forward())};
  }
  auto all = [&](auto outside) {
    for (const Vec3f& v : c)
      if (!outside(v)) return false;
    return true;
  };
  const float n = view.near(), f = view.far();
  if (all([&](Vec3f v) { return v.z < n; }) || all([&](Vec3f v) { return v.z > f; })) return true;
  const float l = view.window_left(), r = view.window_right(), b = view.window_bottom(), t = view.window_top();
  if (view.is_perspective()) {
    // The window [l, r] x [b, t] lies at depth near: the side planes are x = (l / near) z etc.
    const float sl = l / n, sr = r / n, sb = b / n, st = t / n;
    return all([&](Vec3f v) { return v.x < sl * v.z; }) || all([&](Vec3f v) { return v.x > sr * v.z; }) ||
           all([&](Vec3f v) { return v.y < sb * v.z; }) || all([&](Vec3f v) { return v.y > st * v.z; });
  }
  return all([&](Vec3f v) { return v.x < l; }) || all([&](Vec3f v) { return v.x > r; }) ||
         all([&](Vec3f v) { return v.y < b; }) || all([&](Vec3f v) { return v.y > t; });
}

void CasterCulling::build(RasterTriangleView triangles) {
  runs_.clear();
  triangles_ = triangles.size();
  size_t i = 0;
  while (i < triangles.size()) {
    Run run{i, i, {}};
    const uint32_t object = triangles[i].object;
    while (run.end < triangles.size() && triangles[run.end].object == object && run.end - run.begin < kRunTriangles) {
      for (const Vec3f& p : triangles[run.end].p) run.bounds.extend(p);
      ++run.end;
    }
    i = run.end;
    runs_.push_back(run);
  }
}

RasterTriangleView CasterCulling::visible(RasterTriangleView triangles, const LightView& view,
                                          std::vector<RasterTriangle>& scratch, uint64_t* culled) const {
  if (triangles.size() != triangles_) throw Error("CasterCulling: the list changed since build()");
  std::vector<char> keep(runs_.size());
  size_t kept = 0;
  for (size_t r = 0; r < runs_.size(); ++r) {
    keep[r] = !box_outside_view(runs_[r].bounds, view);
    if (keep[r]) kept += runs_[r].end - runs_[r].begin;
  }
  if (culled) *culled = triangles.size() - kept;
  if (kept == triangles.size()) return triangles;
  scratch.clear();
  scratch.reserve(kept);
  for (size_t r = 0; r < runs_.size(); ++r)
    if (keep[r]) scratch.insert(scratch.end(), triangles.list.begin() + runs_[r].begin, triangles.list.begin() + runs_[r].end);
  return RasterTriangleView(std::span<const RasterTriangle>(scratch), triangles.textures);
}

}  // namespace penumbra
