#include "penumbra/scene/camera.h"
#include "penumbra/scene/camera_shared.h"

#include <cmath>
#include <cstdint>

#include <fmt/format.h>

#include "penumbra/core/error.h"

namespace penumbra {

bool parse_resolution(const std::string& text, int* width, int* height) {
  // Digits, then optionally 'x' and digits: at most 5 digits a side, so no overflow.
  auto side = [](const std::string& t, int* out) {
    if (t.empty() || t.size() > 5) return false;
    int v = 0;
    for (char c : t) {
      if (c < '0' || c > '9') return false;
      v = v * 10 + (c - '0');
    }
    *out = v;
    return v >= 1 && v <= 16384;
  };
  const size_t x = text.find('x');
  int w = 0, h = 0;
  if (x == std::string::npos) {
    if (!side(text, &w)) return false;
    h = w;
  } else if (!side(text.substr(0, x), &w) || !side(text.substr(x + 1), &h)) {
    return false;
  }
  *width = w;
  *height = h;
  return true;
}

std::string PixelWindow::to_string() const { return fmt::format("{},{},{},{}", x0, y0, x1, y1); }

PixelWindow crop_window(const PixelWindow& crop, const Camera& camera) {
  if (crop.empty()) return PixelWindow{0, 0, camera.width, camera.height};
  if (!crop.inside(camera.width, camera.height))
    throw Error("crop={}: outside the {}x{} image", crop.to_string(), camera.width, camera.height);
  return crop;
}

bool parse_pixel_window(const std::string& text, PixelWindow* window) {
  // Four comma-separated non-negative integers of at most 5 digits (an image side is at most
  // 16384), so no overflow.
  int v[4] = {};
  size_t at = 0;
  for (int i = 0; i < 4; ++i) {
    const size_t end = i < 3 ? text.find(',', at) : text.size();
    if (end == std::string::npos) return false;
    const std::string part = text.substr(at, end - at);
    if (part.empty() || part.size() > 5) return false;
    for (char c : part) {
      if (c < '0' || c > '9') return false;
      v[i] = v[i] * 10 + (c - '0');
    }
    at = end + 1;
  }
  if (!(v[0] < v[2] && v[1] < v[3])) return false;
  *window = PixelWindow{v[0], v[1], v[2], v[3]};
  return true;
}

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

Vec3f Camera::ray_direction(float px, float py) const { return CameraProjection(*this).ray_direction(px, py); }

CameraProjection::CameraProjection(const Camera& camera)
    : frame_(camera.frame()),
      tan_half_(std::tan(radians(camera.fov_y) * 0.5f)),
      aspect_(static_cast<float>(camera.width) / static_cast<float>(camera.height)),
      width_(static_cast<float>(camera.width)),
      height_(static_cast<float>(camera.height)) {}

// Both functions below are compiled with the same flags (CMakeLists.txt: no contraction into
// fused multiply-adds, no errno from sqrt), so the row loop vectorises and gives the same
// floats as one ray at a time.
Vec3f CameraProjection::ray_direction(float px, float py) const {
  // camera_shared.h: the GPU's camera pass uses the same function.
  return shader::camera_ray_direction(frame_.s, frame_.t, frame_.n, tan_half_, aspect_, width_, height_, px, py);
}

void CameraProjection::row_directions(float py, int x_begin, int count, float* __restrict dx, float* __restrict dy,
                                      float* __restrict dz) const {
  const float y = (1.0f - 2.0f * py / height_) * tan_half_;
  const Vec3f ty = frame_.t * y;
  const Vec3f s = frame_.s, n = frame_.n;
  for (int i = 0; i < count; ++i) {
    // ray_direction's arithmetic, component by component, in the same order.
    const float x = (2.0f * (static_cast<float>(x_begin + i) + 0.5f) / width_ - 1.0f) * tan_half_ * aspect_;
    const float vx = (s.x * x + ty.x) - n.x, vy = (s.y * x + ty.y) - n.y, vz = (s.z * x + ty.z) - n.z;
    const float r = 1.0f / std::sqrt(vx * vx + vy * vy + vz * vz);
    dx[i] = vx * r;
    dy[i] = vy * r;
    dz[i] = vz * r;
  }
}

}  // namespace penumbra
