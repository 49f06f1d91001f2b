#include "penumbra/render/coherent_shading.h"

#include <algorithm>
#include <cmath>

namespace penumbra {

CoherentShading::CoherentShading(const Scene& scene, Vec3f light_point) : scene_(&scene) {
  bend_.resize(scene.objects.size());
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    const SceneObject& obj = scene.objects[o];
    const TriangleMesh& m = obj.mesh;
    if (!obj.closed || m.normals.empty()) continue;
    std::vector<float>& bend = bend_[o];
    bend.assign(m.positions.size(), 1.0f);
    // Vertices split by normals are welded by position first, so a seam's copies share
    // their faces (otherwise each copy would see only half the faces around it).
    std::vector<uint32_t> weld(m.positions.size());
    {
      std::vector<uint32_t> order(m.positions.size());
      for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
      auto less = [&](uint32_t a, uint32_t b) {
        const Vec3f p = m.positions[a], q = m.positions[b];
        return p.x < q.x || (p.x == q.x && (p.y < q.y || (p.y == q.y && p.z < q.z)));
      };
      std::sort(order.begin(), order.end(), less);
      for (size_t i = 0; i < order.size(); ++i)
        weld[order[i]] = (i > 0 && !less(order[i - 1], order[i])) ? weld[order[i - 1]] : order[i];
    }
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      const uint32_t i[3] = {m.indices[t], m.indices[t + 1], m.indices[t + 2]};
      const Vec3f n = cross(m.positions[i[1]] - m.positions[i[0]], m.positions[i[2]] - m.positions[i[0]]);
      const float len = length(n);
      if (!(len > 0)) continue;
      for (uint32_t v : i) {
        const Vec3f l = normalize(light_point - m.positions[v]);
        float& b = bend[weld[v]];
        b = std::min(b, dot(l, n) / len);
      }
    }
    for (size_t v = 0; v < bend.size(); ++v) bend[v] = bend[weld[v]];
  }
}

float CoherentShading::bent_cosine(const ViewSample& s) const {
  if (!scene_ || bend_[s.object].empty()) return 1.0f;
  const TriangleMesh& m = scene_->objects[s.object].mesh;
  const uint32_t i0 = m.indices[3 * s.prim], i1 = m.indices[3 * s.prim + 1], i2 = m.indices[3 * s.prim + 2];
  const Vec3f a = m.positions[i0], b = m.positions[i1], c = m.positions[i2];
  const Vec3f n = cross(b - a, c - a);
  const float area = dot(n, n);
  if (!(area > 0)) return bend_[s.object][i0];
  // Barycentrics of p (on the triangle up to rounding).
  const float w1 = dot(cross(s.p - a, c - a), n) / area, w2 = dot(cross(b - a, s.p - a), n) / area;
  const std::vector<float>& bend = bend_[s.object];
  return bend[i0] * (1 - w1 - w2) + bend[i1] * w1 + bend[i2] * w2;
}

float CoherentShading::factor(const ViewSample& s, Vec3f light_point) const {
  if (!scene_ || bend_[s.object].empty()) return 1.0f;
  const float lf = dot(normalize(light_point - s.p), s.ns);
  if (!(lf > 0)) return 1.0f;  // the smooth irradiance is (about) 0 already
  const float lb = bent_cosine(s);
  const float alpha = std::min(1.0f, std::max(kC * lb, 0.0f));
  return std::clamp((alpha * lf + (1 - alpha) * lb) / lf, 0.0f, 1.0f);
}

}  // namespace penumbra
