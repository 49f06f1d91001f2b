#include "penumbra/shadow/light_horizon.h"

#include <cmath>
#include <numbers>

namespace penumbra {

Vec2f light_half_axes(const AreaLight& light) {
  const float k = 0.5f * std::sqrt(std::numbers::pi_v<float>);
  switch (light.shape) {
    case LightShape::Rect: return {0.5f * light.size.x, 0.5f * light.size.y};
    case LightShape::Ellipsoid: return {k * light.radii.x, k * light.radii.y};
    default: return {k * light.radius, k * light.radius};
  }
}

shader::HorizonLight horizon_light(const AreaLight& light) {
  shader::HorizonLight l{};
  const Vec2f h = light_half_axes(light);
  l.center = light.center;
  l.n = light.frame.n;
  l.s = light.frame.s;
  l.t = light.frame.t;
  l.half_s = h.x;
  l.half_t = h.y;
  return l;
}

float light_fraction_above(const AreaLight& light, Vec3f p, Vec3f ng) {
  return shader::light_fraction_above(horizon_light(light), p, ng);
}

}  // namespace penumbra
