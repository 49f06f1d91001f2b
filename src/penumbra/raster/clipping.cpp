#include "penumbra/raster/clipping.h"

namespace penumbra::raster_internal {

TriangleClipper::TriangleClipper(const LightView& view)
    : eye_(view.eye()), near_(view.near()), far_(view.far()), x_max_(static_cast<float>(view.width()) + kGuardBand),
      y_max_(static_cast<float>(view.height()) + kGuardBand) {
  const Mat4& m = view.texel_projection();
  for (int c = 0; c < 4; ++c) col_[c] = Float4{m.m[0][c], m.m[1][c], m.m[2][c], m.m[3][c]};
}

int TriangleClipper::clip(const RasterTriangle& t, ClipVertex out[kMaxClipVertices]) const {
  // Signed distance to each clip plane (>= 0 inside).
  auto distance = [&](int plane, const ClipVertex& v) {
    switch (plane) {
      case 0: return v.z - near_;
      case 1: return far_ - v.z;
      case 2: return v.x + kGuardBand * v.w;
      case 3: return x_max_ * v.w - v.x;
      case 4: return v.y + kGuardBand * v.w;
      default: return y_max_ * v.w - v.y;
    }
  };
  unsigned any = 0, all = ~0u;
  for (int k = 0; k < 3; ++k) {
    const Vec3f p = t.p[k] - eye_;  // texel_projection takes p - eye
    Float4 h = col_[0] * p.x + col_[1] * p.y + col_[2] * p.z + col_[3];
    ClipVertex& v = out[k];
    v = {h[0], h[1], h[2], h[3]};
    unsigned code = unsigned(v.z < near_) | unsigned(v.z > far_) << 1 |
                    unsigned(v.x < -kGuardBand * v.w) << 2 | unsigned(v.x > x_max_ * v.w) << 3 |
                    unsigned(v.y < -kGuardBand * v.w) << 4 | unsigned(v.y > y_max_ * v.w) << 5;
    any |= code;
    all &= code;
  }
  if (all != 0) return 0;  // every vertex outside one plane
  if (any == 0) return 3;  // the common case: nothing to clip

  // Sutherland-Hodgman, one plane at a time, only against the planes some vertex violates.
  ClipVertex buf[kMaxClipVertices];
  ClipVertex* src = out;
  ClipVertex* dst = buf;
  int n = 3;
  for (int p = 0; p < 6 && n > 0; ++p) {
    if (!(any & (1u << p))) continue;
    int m_out = 0;
    for (int i = 0; i < n; ++i) {
      const ClipVertex& a = src[i];
      const ClipVertex& b = src[(i + 1) % n];
      float da = distance(p, a), db = distance(p, b);
      if (da >= 0) dst[m_out++] = a;
      if ((da >= 0) != (db >= 0)) {
        // Interpolate from the inside vertex toward the outside one, so the two triangles
        // sharing this edge compute the very same point (no crack along the clip line).
        const ClipVertex& in = da >= 0 ? a : b;
        const ClipVertex& o = da >= 0 ? b : a;
        float din = da >= 0 ? da : db, dout = da >= 0 ? db : da;
        float s = din / (din - dout);
        dst[m_out++] = {in.x + (o.x - in.x) * s, in.y + (o.y - in.y) * s,
                        in.z + (o.z - in.z) * s, in.w + (o.w - in.w) * s};
      }
    }
    n = m_out;
    std::swap(src, dst);
  }
  if (src != out)
    for (int i = 0; i < n; ++i) out[i] = src[i];
  return n >= 3 ? n : 0;
}

}  // namespace penumbra::raster_internal
