#include "penumbra/render/coherent_shading.h"

#include <gtest/gtest.h>

#include "penumbra/render/renderer.h"
#include "penumbra/scene/shapes.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using namespace penumbra::testing;

// A view sample on triangle t of a mesh near its corner k (barycentric 0.8 there), with the
// interpolated normal.
ViewSample corner_sample(const TriangleMesh& m, size_t t, int k, uint32_t object) {
  const uint32_t i[3] = {m.indices[3 * t], m.indices[3 * t + 1], m.indices[3 * t + 2]};
  const float w[3] = {k == 0 ? 0.8f : 0.1f, k == 1 ? 0.8f : 0.1f, k == 2 ? 0.8f : 0.1f};
  ViewSample s;
  s.p = m.positions[i[0]] * w[0] + m.positions[i[1]] * w[1] + m.positions[i[2]] * w[2];
  s.ng = normalize(cross(m.positions[i[1]] - m.positions[i[0]], m.positions[i[2]] - m.positions[i[0]]));
  s.ns = normalize(m.normals[i[0]] * w[0] + m.normals[i[1]] * w[1] + m.normals[i[2]] * w[2]);
  s.object = object;
  s.prim = static_cast<uint32_t>(t);
  return s;
}

TEST(CoherentShading, DarkOnBackFacingFacesUnchangedWhereAllFacesFaceTheLight) {
  TriangleMesh sphere = make_uv_sphere(1.0f, 24);
  for (Vec3f& p : sphere.positions) p = p + Vec3f(0, 1.5f, 0);
  Scene scene = ground_scene({object(sphere)}, rect_light_down({0, 6, 0}, 0.5f, 0.5f));
  ASSERT_TRUE(scene.objects[1].closed);
  ASSERT_FALSE(scene.objects[1].mesh.normals.empty());
  const Vec3f light = scene.lights[0].center;
  const CoherentShading coherent(scene, light);
  const TriangleMesh& m = scene.objects[1].mesh;
  int dark = 0, kept = 0, blended = 0;
  for (size_t t = 0; t < m.indices.size() / 3 * 3; ++t) {
    const ViewSample s = corner_sample(m, t / 3, static_cast<int>(t % 3), 1);
    const float f = coherent.factor(s, light);
    ASSERT_GE(f, 0.0f);
    ASSERT_LE(f, 1.0f);
    const float face = dot(s.ng, normalize(light - s.p));
    const float smooth = dot(s.ns, normalize(light - s.p));
    if (face < 0 && smooth > 0) {
      EXPECT_EQ(f, 0.0f) << t;  // the leak the smooth normal would give is gone
      ++dark;
    }
    if (coherent.bent_cosine(s) >= 1 / CoherentShading::kC) {
      EXPECT_EQ(f, 1.0f) << t;
      ++kept;
    } else if (smooth > 0 && face > 0) {
      ++blended;
    }
  }
  EXPECT_GT(dark, 0);
  EXPECT_GT(kept, 0);
  EXPECT_GT(blended, 0);
  // The ground (open) is not touched.
  ViewSample g;
  g.p = {2, 0, 0};
  g.ng = g.ns = {0, 1, 0};
  g.object = 0;
  EXPECT_EQ(coherent.factor(g, light), 1.0f);
  EXPECT_EQ(CoherentShading().factor(g, light), 1.0f);
}

TEST(CoherentShading, RenderOptionOnlyDarkens) {
  TriangleMesh sphere = make_uv_sphere(0.6f, 20);
  for (Vec3f& p : sphere.positions) p = p + Vec3f(0, 0.8f, 0);
  Scene scene = ground_scene({object(sphere)}, rect_light_down({1.5f, 3, 0}, 0.5f, 0.5f), 48);
  RenderSettings settings;
  settings.method = "hard";
  const RenderResult plain = render_scene(scene, settings);
  settings.coherent_shading = true;
  const RenderResult bent = render_scene(scene, settings);
  int darker = 0;
  for (int i = 0; i < 48 * 48; ++i) {
    EXPECT_LE(bent.color.data()[3 * i], plain.color.data()[3 * i] + 1e-6f);
    darker += bent.color.data()[3 * i] < plain.color.data()[3 * i] - 1e-6f;
  }
  EXPECT_GT(darker, 0);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
