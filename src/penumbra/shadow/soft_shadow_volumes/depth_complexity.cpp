#include "penumbra/shadow/soft_shadow_volumes/depth_complexity.h"

#include <cmath>

#include "penumbra/shadow/soft_shadow_volumes/crossing_kernel.h"

namespace penumbra::ssv {
namespace {

struct D3 {
  double x, y, z;
};
inline D3 sub(Vec3f p, Vec3f o) { return {double(p.x) - o.x, double(p.y) - o.y, double(p.z) - o.z}; }
inline D3 operator-(D3 a, D3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline D3 cross(D3 a, D3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double dot(D3 a, D3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// §3.2: k_e, the change of D across the edge, from the plane (o, a, b) with normal m (all
// relative to o): each triangle adds the side of its third vertex.
int weight(const SilhouetteEdge& e, Vec3f o, D3 m) {
  int k = 0;
  for (uint32_t t = 0; t < e.triangles; ++t) {
    const double s = dot(m, sub(e.w[t], o));
    k += (s > 0) - (s < 0);
  }
  return k;
}

}  // namespace

EdgeFacing edge_facing(const SilhouetteEdge& e) {
  EdgeFacing f;
  f.two_sided = e.triangles == 2;
  for (uint32_t t = 0; t < e.triangles; ++t) {
    const D3 a = sub(e.a, Vec3f(0.0f)), n = cross(sub(e.b, e.a), sub(e.w[t], e.a));
    f.n[t] = Vec3f(float(n.x), float(n.y), float(n.z));
    f.d[t] = float(-dot(n, a));
    f.scale[t] = float(std::sqrt(dot(n, n)));
  }
  return f;
}

int edge_weight(const SilhouetteEdge& e, Vec3f o) { return weight(e, o, cross(sub(e.a, o), sub(e.b, o))); }

bool add_edge_crossings(const SilhouetteEdge& e, Vec3f o, Vec3f r, const SampleOffsets& samples, int32_t* depth) {
  const D3 a = sub(e.a, o), b = sub(e.b, o), rr{r.x, r.y, r.z};
  D3 m = cross(a, b);
  const int k = weight(e, o, m);
  const double side_r = dot(m, rr);
  if (k == 0 || side_r == 0) return false;
  // Oriented so that r is on the positive side of every test (depth_complexity.h): a crossing
  // sample has m . l < 0, u . l > u . a (the line a-b on o's side of r-l: det[b - a, r - a,
  // l - a] has the sign of det[b - a, o - a, r - a] = m . r) and (a x r) . l, (b x r) . l of
  // opposite signs (a and b on either side of the plane (o, r, l)).
  const double sign = side_r > 0 ? 1.0 : -1.0;
  m = {m.x * sign, m.y * sign, m.z * sign};
  D3 u = cross(b - a, rr - a);
  u = {u.x * sign, u.y * sign, u.z * sign};
  const double ua = dot(u, a);
  const D3 alpha = cross(a, rr), beta = cross(b, rr);
  // Sweeping from r over the edge onto m's negative side enters the triangles there and
  // leaves those on the positive side: D changes by -k (k counted with the unflipped m).
  const int32_t delta = side_r > 0 ? -k : k;
  // The per-sample tests in float (SIMD, crossing_kernel.h), the per-edge set-up above in
  // double: the small triangles of a fine mesh seen from afar make the cross products cancel.
  const CrossingTests tests{{float(m.x), float(m.y), float(m.z)},
                            {float(u.x), float(u.y), float(u.z)},
                            {float(alpha.x), float(alpha.y), float(alpha.z)},
                            {float(beta.x), float(beta.y), float(beta.z)},
                            float(ua)};
  add_crossings(tests, samples.x, samples.y, samples.z, padded_samples(static_cast<size_t>(samples.count)), delta,
                depth);
  return true;
}

}  // namespace penumbra::ssv
