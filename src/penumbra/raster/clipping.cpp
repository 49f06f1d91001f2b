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
    unsigned code = 0;
    for (int p = 0; p < 6; ++p)
      if (distance(p, v) < 0) code |= 1u << p;
    return code;
  }
};

}  // namespace

int clip_triangle(const RasterTriangle& t, const LightView& view, ClipVertex out[kMaxClipVertices]) {
  const Mat4& m = view.texel_projection();
  ClipPlanes planes{view.near(), view.far(), static_cast<float>(view.width()) + kGuardBand,
                    static_cast<float>(view.height()) + kGuardBand};
  unsigned any = 0, all = ~0u;
  for (int k = 0; k < 3; ++k) {
    float h[4];
    m.transform_homogeneous(t.p[k], h);
    out[k] = {h[0], h[1], h[2], h[3]};
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
