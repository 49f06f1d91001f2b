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

// A rectangle of a camera's image in pixels, half-open: [x0, x1) x [y0, y1), (0, 0) the top
// left pixel. A render's crop (RenderSettings::crop): the pixels it renders, where an empty
// window (no pixels, as the default) stands for the whole image.
struct PixelWindow {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool empty() const { return x1 <= x0 || y1 <= y0; }
  int width() const { return x1 - x0; }
  int height() const { return y1 - y0; }
  // Whether every pixel lies inside a width x height image.
  bool inside(int width, int height) const { return x0 >= 0 && y0 >= 0 && x1 <= width && y1 <= height; }
  bool operator==(const PixelWindow&) const = default;
  std::string to_string() const;  // "X0,Y0,X1,Y1"
};

// The pixels a render with `crop` covers: the whole image when crop is empty, otherwise crop.
// Throws an Error naming the crop when it is not inside the camera's image.
PixelWindow crop_window(const PixelWindow& crop, const Camera& camera);

// A window as the command line takes it: "X0,Y0,X1,Y1", four integers with X0 < X1 and Y0 <
// Y1 (the image size is checked by crop_window). False for anything else.
bool parse_pixel_window(const std::string& text, PixelWindow* window);

// An image size as the command line and the viewer take it: "N" (N x N) or "WxH", each
// side in [1, 16384] (a scene file's camera.resolution range). False for anything else.
bool parse_resolution(const std::string& text, int* width, int* height);

// Camera::ray_direction with the frame and the field-of-view scale computed once, for loops
// over every pixel (the camera pass): the same arithmetic, so the same directions bit for bit.
class CameraProjection {
 public:
  explicit CameraProjection(const Camera& camera);
  Vec3f ray_direction(float px, float py) const;
  // ray_direction(x + 0.5, py) for the pixel centres x = x_begin .. x_begin+count-1 of one
  // row, into (dx[x - x_begin], ...): the same floats, in a loop the compiler vectorises.
  void row_directions(float py, int x_begin, int count, float* dx, float* dy, float* dz) const;
  // What the GPU's camera pass takes to compute the same directions (camera_shared.h).
  const Frame& frame() const { return frame_; }
  float tan_half() const { return tan_half_; }
  float aspect() const { return aspect_; }

 private:
  Frame frame_;
  float tan_half_, aspect_, width_, height_;
};

}  // namespace penumbra
