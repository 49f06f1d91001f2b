// A furball: a closed sphere covered in thin hair strands, each a ribbon of a few quads
// with its own opacity. The analogue of xie2007's fur scene (§7): many thin,
// semi-transparent casters that a single-layer shadow map cannot represent.
//
// Opacity convention: the hair object's Material::opacity stays 1 and each strand's
// opacity is written to TriangleMesh::triangle_opacity (the effective opacity is their
// product), so one object holds strands of different opacity.
#include "penumbra/core/error.h"
#include "penumbra/core/rng.h"
#include "penumbra/scene/generators.h"
#include "penumbra/scene/shapes.h"

namespace penumbra {
namespace {

using nlohmann::json;

std::vector<SceneObject> generate_furball(const json& params) {
  const uint64_t seed = params["seed"].get<uint64_t>();
  const int strands = params["strands"].get<int>(), segments = params["segments"].get<int>();
  const float radius = params["radius"].get<float>(), length = params["length"].get<float>();
  const float width = params["width"].get<float>(), droop = params["droop"].get<float>();
  const float op_min = params["opacity_min"].get<float>(), op_max = params["opacity_max"].get<float>();
  if (op_min > op_max)
    throw Error("opacity_min ({}) must not exceed opacity_max ({})", op_min, op_max);
  // Strands are at most `length` long, so nothing reaches below y = 0.
  const Vec3f centre(0, radius + length, 0);

  SceneObject body;
  body.name = "body";
  body.mesh = make_uv_sphere(radius, params["body_segments"].get<int>());
  body.mesh.transform(Mat4::translate(centre));
  body.sphere = SphereShape{centre, radius};
  body.material.albedo = Vec3f(0.45f, 0.3f, 0.2f);

  SceneObject hair;
  hair.name = "hair";
  hair.material.albedo = Vec3f(0.6f, 0.42f, 0.28f);
  TriangleMesh& m = hair.mesh;
  m.positions.reserve(static_cast<size_t>(strands) * 2 * (segments + 1));
  m.indices.reserve(static_cast<size_t>(strands) * 6 * segments);
  m.triangle_opacity.reserve(static_cast<size_t>(strands) * 2 * segments);
  for (int s = 0; s < strands; ++s) {
    // One stream per strand: strand s is the same whatever the strand count.
    Rng rng(seed, 0x66757262 /* "furb" */, static_cast<uint64_t>(s));
    // Root: uniform on the sphere.
    float z = 1 - 2 * rng.next_float(), phi = 2 * kPi * rng.next_float();
    float rxy = std::sqrt(std::max(0.0f, 1 - z * z));
    Vec3f n(rxy * std::cos(phi), z, rxy * std::sin(phi));
    // Ribbon width axis: a random direction around the root normal, so the ribbons do
    // not all face one way.
    Vec3f t0, t1;
    coordinate_system(n, &t0, &t1);
    float twist = 2 * kPi * rng.next_float();
    Vec3f side = t0 * std::cos(twist) + t1 * std::sin(twist);
    const float strand_len = length * (0.75f + 0.25f * rng.next_float());
    const float opacity = op_min + (op_max - op_min) * rng.next_float();
    Vec3f p = centre + n * (radius * 0.995f);  // rooted just inside the skin: no gap
    Vec3f dir = n;
    const uint32_t base = static_cast<uint32_t>(m.positions.size());
    for (int i = 0; i <= segments; ++i) {
      float taper = 1 - 0.7f * i / segments;
      Vec3f sd = normalize(side - dir * dot(side, dir));
      m.positions.push_back(p - sd * (0.5f * width * taper));
      m.positions.push_back(p + sd * (0.5f * width * taper));
      if (i == segments) break;
      p += dir * (strand_len / segments);
      // Gravity bends the strand down; a little noise makes it wavy.
      Vec3f jitter(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f);
      dir = normalize(dir + Vec3f(0, -droop / segments, 0) + jitter * 0.3f);
    }
    for (int i = 0; i < segments; ++i) {
      uint32_t l0 = base + 2 * i, r0 = l0 + 1, l1 = l0 + 2, r1 = l0 + 3;
      m.indices.insert(m.indices.end(), {l0, r0, r1, l0, r1, l1});
      m.triangle_opacity.insert(m.triangle_opacity.end(), {opacity, opacity});
    }
  }
  return {std::move(body), std::move(hair)};
}

json furball_example(const json& params) {
  ExampleSceneLayout layout;
  layout.target = Vec3f(0, 0.5f, 0);
  json object = {{"generator", "furball"}, {"params", params}, {"translate", json::array({0, 0.15, 0})}};
  return example_scene_document(object, layout);
}

GeneratorRegistration reg(GeneratorInfo{
    "furball",
    "a closed sphere with hair strands as thin ribbons of per-strand opacity, floating just above y = 0",
    {
        {"seed", 1, "random seed: same seed, same furball", 0, 2147483647},
        {"strands", 2000, "number of hair strands", 0, 1000000},
        {"segments", 4, "quads per strand (2 triangles each)", 1, 64},
        {"radius", 0.3, "body sphere radius", 1e-4, 100},
        {"body_segments", 48, "body sphere slices (stacks = half)", 3, 1024},
        {"length", 0.22, "longest strand length (strands are 75-100% of it)", 1e-4, 100},
        {"width", 0.008, "ribbon width at the root (tapers to 30% at the tip)", 1e-6, 10},
        {"droop", 0.8, "how much gravity bends the strands (0 = straight out)", 0, 10},
        {"opacity_min", 0.3, "lowest strand opacity", 0, 1},
        {"opacity_max", 0.9, "highest strand opacity", 0, 1},
    },
    generate_furball,
    furball_example,
});

}  // namespace
}  // namespace penumbra
