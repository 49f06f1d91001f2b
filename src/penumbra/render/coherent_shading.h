// Coherent shading for exact shadows (sintorn2008 §4.3 "Shading", Fig. 8). A smooth mesh's
// interpolated normal still faces the light a little way into the light back-facing
// triangles, which an exact shadow method (rightly) shadows: a hard dark seam follows the
// terminator. The paper bends the shading toward the faces: per vertex
//   l_bend(v) = min over the faces F around v of dot(l, n_F)   (l: unit vector to the light)
// interpolated over the triangle, then blended back to the smooth cosine l_f:
//   alpha = min(1, max(c l_bend, 0)),  shading = alpha l_f + (1 - alpha) l_bend,  c = 3,
// which is 0 on every light back-facing triangle and l_f where all faces around face the
// light. Here it is a factor on the smooth irradiance: shading / l_f, clamped to [0, 1]
// (compose multiplies E0(p, ns) V by it). It applies to closed meshes with vertex normals
// (elsewhere "back-facing" has no meaning, or there is nothing smooth to bend) and uses the
// light's centre for l ("bent normals with respect to the source's center are often
// sufficient").
#pragma once

#include <vector>

#include "penumbra/scene/scene.h"
#include "penumbra/shadow/view_samples.h"

namespace penumbra {

class CoherentShading {
 public:
  static constexpr float kC = 3.0f;
  CoherentShading() = default;  // off: factor() is 1
  CoherentShading(const Scene& scene, Vec3f light_point);
  bool enabled() const { return scene_ != nullptr; }
  // The interpolated l_bend at p on the sample's triangle (1 when not applicable).
  float bent_cosine(const ViewSample& s) const;
  // The factor on the smooth-normal irradiance of view sample s, in [0, 1].
  float factor(const ViewSample& s, Vec3f light_point) const;

 private:
  const Scene* scene_ = nullptr;
  std::vector<std::vector<float>> bend_;  // per object, per vertex (empty: not applicable)
};

}  // namespace penumbra
