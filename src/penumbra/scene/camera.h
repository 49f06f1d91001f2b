// A pinhole camera: eye, target, up, vertical field of view, resolution.
#pragma once

#include <string>

#include "penumbra/core/math.h"

namespace penumbra {

struct Camera {
  Vec3f eye{0, 1, 5}, target{0, 0, 0}, up{0, 1, 0};
  float fov_y = 45.0f;  // degrees
  int width = 512, height = 512;
  int samples_per_pixel = 1;  // jittered supersampling of the camera pass

  // Unit direction of the ray through image position (px, py) in pixels, (0,0) the top
  // left corner of the image, (width, height) the bottom right.
  Vec3f ray_direction(float px, float py) const;
  Frame frame() const;  // s = right, t = up, n = backward (-view direction)
};

// An image size as the command line and the viewer take it: "N" (N x N) or "WxH", each
// side in [1, 16384] (a scene file's camera.resolution range). False for anything else.
bool parse_resolution(const std::string& text, int* width, int* height);

// Camera::ray_direction with the frame and the field-of-view scale computed once, for loops
// over every pixel (the camera pass): the same arithmetic, so the same directions bit for bit.
class CameraProjection {
 public:
  explicit CameraProjection(const Camera& camera);
  Vec3f ray_direction(float px, float py) const;
  // ray_direction(x + 0.5, py) for the pixel centres x = 0 .. count-1 of one row, into
  // (dx[x], dy[x], dz[x]): the same floats, in a loop the compiler vectorises.
  void row_directions(float py, int count, float* dx, float* dy, float* dz) const;

 private:
  Frame frame_;
  float tan_half_, aspect_, width_, height_;
};

}  // namespace penumbra
