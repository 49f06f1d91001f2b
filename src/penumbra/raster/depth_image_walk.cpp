#include "penumbra/raster/depth_image_walk.h"

namespace penumbra {

bool project_to_depth_image(const LightView& view, Vec3f a, Vec3f b, ProjectedSegment* out) {
  float ha[4], hb[4];
  view.texel_projection().transform_homogeneous(a, ha);
  view.texel_projection().transform_homogeneous(b, hb);
  // Row 2 is the linear depth, affine in the world parameter s: clip s to [near, far].
  float s0 = 0, s1 = 1;
  float za = ha[2], dz = hb[2] - ha[2];
  const float n = view.near(), f = view.far();
  if (dz == 0) {
    if (za < n || za > f) return false;
  } else {
    float sa = (n - za) / dz, sb = (f - za) / dz;
    if (sa > sb) std::swap(sa, sb);
    s0 = std::max(s0, sa);
    s1 = std::min(s1, sb);
    if (s0 > s1) return false;
  }
  auto at = [&](float s, float h[4]) {
    for (int i = 0; i < 4; ++i) h[i] = ha[i] + (hb[i] - ha[i]) * s;
  };
  float h0[4], h1[4];
  at(s0, h0);
  at(s1, h1);
  // Clipping can leave a depth a rounding error outside [near, far]; w stays positive.
  float z0 = std::clamp(h0[2], n, f), z1 = std::clamp(h1[2], n, f);
  float w0 = view.is_perspective() ? z0 : 1.0f, w1 = view.is_perspective() ? z1 : 1.0f;
  out->segment.p0 = {h0[0] / w0, h0[1] / w0};
  out->segment.p1 = {h1[0] / w1, h1[1] / w1};
  out->segment.d0 = view.window_depth(z0);
  out->segment.d1 = view.window_depth(z1);
  out->segment.t0 = 0;
  out->segment.t1 = 1;
  out->s0 = s0;
  out->s1 = s1;
  out->w0 = w0;
  out->w1 = w1;
  out->z0 = z0;
  out->z1 = z1;
  return true;
}

}  // namespace penumbra
