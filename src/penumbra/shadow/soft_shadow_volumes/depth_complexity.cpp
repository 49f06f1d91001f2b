#include "penumbra/shadow/soft_shadow_volumes/depth_complexity.h"

#include <cmath>

#include "penumbra/shadow/soft_shadow_volumes/crossing_kernel.h"
#include "penumbra/shadow/soft_shadow_volumes/ssv_shared.h"

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
  // The per-edge set-up in double (ssv_shared.h, shared with the GPU kernel), the per-sample
  // tests in float (SIMD, crossing_kernel.h: ssv_sample_crosses' rounding).
  shader::SsvCrossing c;
  if (!shader::ssv_edge_crossing(e.a, e.b, e.w[0], e.w[1], e.triangles, o, r, c)) return false;
  const CrossingTests tests{{c.m.x, c.m.y, c.m.z}, {c.u.x, c.u.y, c.u.z}, {c.alpha.x, c.alpha.y, c.alpha.z},
                            {c.beta.x, c.beta.y, c.beta.z}, c.ua};
  add_crossings(tests, samples.x, samples.y, samples.z, padded_samples(static_cast<size_t>(samples.count)), c.delta,
                depth);
  return true;
}

}  // namespace penumbra::ssv
