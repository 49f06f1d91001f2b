#include "penumbra/raster/clipping.h"

namespace penumbra::raster_internal {
namespace {

// Signed distances to the six clip planes (>= 0 inside), in homogeneous texel space.
struct ClipPlanes {
  float near, far, x_max, y_max;
  float distance(int plane, const ClipVertex& v) const {
    switch (plane) {
      case 0: return v.z - near;
      case 1: return far - v.z;
      case 2: return v.x + kGuardBand * v.w;
      case 3: return x_max * v.w - v.x;
      case 4: return v.y + kGuardBand * v.w;
      default: return y_max * v.w - v.y;
    }
  }
  unsigned outcode(const ClipVertex& v) const {
    return unsigned(v.z < near) | unsigned(v.z > far) << 1 | unsigned(v.x < -kGuardBand * v.w) << 2 |
           unsigned(v.x > x_max * v.w) << 3 | unsigned(v.y < -kGuardBand * v.w) << 4 |
           unsigned(v.y > y_max * v.w) << 5;
  }
};

}  // namespace

int clip_triangle(const RasterTriangle& t, const LightView& view, ClipVertex out[kMaxClipVertices]) {
  const Mat4& m = view.texel_projection();
  ClipPlanes planes{view.near(), view.far(), static_cast<float>(view.width()) + kGuardBand,
                    static_cast<float>(view.height()) + kGuardBand};
  unsigned any = 0, all = ~0u;
  const float (*r)[4] = m.m;
  for (int k = 0; k < 3; ++k) {
    const Vec3f& p = t.p[k];
    out[k] = {r[0][0] * p.x + r[0][1] * p.y + r[0][2] * p.z + r[0][3],
              r[1][0] * p.x + r[1][1] * p.y + r[1][2] * p.z + r[1][3],
              r[2][0] * p.x + r[2][1] * p.y + r[2][2] * p.z + r[2][3],
              r[3][0] * p.x + r[3][1] * p.y + r[3][2] * p.z + r[3][3]};
    unsigned code = planes.outcode(out[k]);
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
      float da = planes.distance(p, a), db = planes.distance(p, b);
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
