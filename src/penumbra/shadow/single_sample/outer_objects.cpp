#include "penumbra/shadow/single_sample/outer_objects.h"

namespace penumbra::single_sample {

namespace {
struct RayPoint {
  float t, x, y;  // along the ray, and across it
};

// Clips the polygon to t >= near (sign = +1) or t <= far (sign = -1).
int clip(const RayPoint* in, int n, RayPoint* out, float bound, float sign) {
  int m = 0;
  for (int i = 0; i < n; ++i) {
    const RayPoint& p = in[i];
    const RayPoint& q = in[(i + 1) % n];
    float dp = sign * (p.t - bound), dq = sign * (q.t - bound);
    if (dp >= 0) out[m++] = p;
    if ((dp >= 0) != (dq >= 0)) {
      float s = dp / (dp - dq);
      out[m++] = {p.t + s * (q.t - p.t), p.x + s * (q.x - p.x), p.y + s * (q.y - p.y)};
    }
  }
  return m;
}
}  // namespace

float triangle_cone_distance(Vec3f o, Vec3f v, Vec3f e1, Vec3f e2, float near, float far, Vec3f a, Vec3f b,
                             Vec3f c) {
  RayPoint poly[3], tmp[4], clipped[5];
  int n = 0;
  for (Vec3f x : {a, b, c}) {
    Vec3f r = x - o;
    poly[n++] = {dot(r, v), dot(r, e1), dot(r, e2)};
  }
  n = clip(poly, 3, tmp, near, 1.0f);
  if (n < 3) return kInfinity;
  n = clip(tmp, n, clipped, far, -1.0f);
  if (n < 3) return kInfinity;
  // Perspective projection onto the plane t = 1; the ray's axis is the origin.
  Vec2f q[5];
  for (int i = 0; i < n; ++i) q[i] = {clipped[i].x / clipped[i].t, clipped[i].y / clipped[i].t};
  // Inside test (either winding), then the distance to the nearest edge.
  bool pos = false, neg = false;
  float best2 = kInfinity;
  for (int i = 0; i < n; ++i) {
    Vec2f p = q[i], e = q[(i + 1) % n] - q[i];
    float side = cross(e, Vec2f(0, 0) - p);
    pos |= side > 0;
    neg |= side < 0;
    float len2 = dot(e, e);
    float s = len2 > 0 ? std::clamp(-dot(p, e) / len2, 0.0f, 1.0f) : 0.0f;
    Vec2f closest = p + e * s;
    best2 = std::min(best2, dot(closest, closest));
  }
  // The axis passes through the triangle (or its edge); a projection of zero area (a
  // triangle seen edge-on) has no inside.
  if (pos != neg) return 0.0f;
  return std::sqrt(best2);
}

}  // namespace penumbra::single_sample
