// A (p, q) torus knot tube: a closed, smooth, self-shadowing caster with no flat parts,
// whose shadow has many overlapping penumbrae. The curve winds p times around the torus
// axis (here y: the knot lies flat) and q times around the torus tube.
#include <numeric>

#include "penumbra/core/error.h"
#include "penumbra/scene/generators.h"
#include "penumbra/scene/shapes.h"

namespace penumbra {
namespace {

using nlohmann::json;

std::vector<SceneObject> generate_knot(const json& params) {
  const int p = params["p"].get<int>(), q = params["q"].get<int>();
  const int segments = params["segments"].get<int>(), sides = params["sides"].get<int>();
  const float R = params["major_radius"].get<float>(), r = params["minor_radius"].get<float>();
  const float tube = params["tube_radius"].get<float>();
  // With a common divisor the curve is a link of gcd(p, q) knots and one loop over
  // [0, 2 pi) would trace a component several times.
  if (std::gcd(p, q) != 1) throw Error("p and q must be coprime (got p = {}, q = {})", p, q);
  if (r >= R) throw Error("minor_radius ({}) must be smaller than major_radius ({})", r, R);
  std::vector<Vec3f> curve(segments);
  for (int i = 0; i < segments; ++i) {
    float phi = 2 * kPi * i / segments;
    float ring = R + r * std::cos(q * phi);
    // Lifted so the tube rests on y = 0.
    curve[i] = Vec3f(ring * std::cos(p * phi), r * std::sin(q * phi) + r + tube, ring * std::sin(p * phi));
  }
  SceneObject o;
  o.name = "knot";
  const float radius[1] = {tube};
  o.mesh = make_tube(curve, radius, sides, /*loop=*/true, /*caps=*/false);
  o.material.albedo = Vec3f(0.8f, 0.35f, 0.25f);
  return {std::move(o)};
}

json knot_example(const json& params) {
  ExampleSceneLayout layout;
  layout.target = Vec3f(0, 0.4f, 0);
  // Stood up and lifted off the ground: the shadow spreads into wide overlapping penumbrae.
  json object = {{"generator", "knot"}, {"params", params},
                 {"rotate", json::array({70, 0, 0})}, {"translate", json::array({0, 0.5, 0})}};
  return example_scene_document(object, layout);
}

GeneratorRegistration reg(GeneratorInfo{
    "knot",
    "a (p, q) torus knot tube (closed), lying flat on y = 0, about 1 unit across",
    {
        {"p", 2, "windings around the torus axis", 1, 64},
        {"q", 3, "windings around the torus tube (coprime with p)", 1, 64},
        {"segments", 400, "rings along the curve", 8, 20000},
        {"sides", 16, "vertices around the tube", 3, 256},
        {"major_radius", 0.3, "torus radius (centre to tube centre)", 1e-4, 100},
        {"minor_radius", 0.12, "torus tube radius the curve winds around", 1e-4, 100},
        {"tube_radius", 0.045, "radius of the knot's own tube", 1e-5, 100},
    },
    generate_knot,
    knot_example,
});

}  // namespace
}  // namespace penumbra
