#include "penumbra/scene/camera.h"

namespace penumbra {

Frame Camera::frame() const {
  Vec3f n = normalize(eye - target);  // backward
  Vec3f s = cross(up, n);             // right
  if (length_squared(s) < 1e-12f) {   // up parallel to the view direction: pick any right
    Vec3f t, b;
    coordinate_system(n, &t, &b);
    s = t;
  }
  s = normalize(s);
  return Frame(s, cross(n, s), n);
}

Vec3f Camera::ray_direction(float px, float py) const {
  Frame f = frame();
  float tan_half = std::tan(radians(fov_y) * 0.5f);
  float aspect = static_cast<float>(width) / static_cast<float>(height);
  // Image x grows to the right and y downward; camera-space y grows upward.
  float x = (2.0f * px / width - 1.0f) * tan_half * aspect;
  float y = (1.0f - 2.0f * py / height) * tan_half;
  return normalize(f.s * x + f.t * y - f.n);
}

}  // namespace penumbra
