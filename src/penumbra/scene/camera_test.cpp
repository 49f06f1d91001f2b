#include "penumbra/scene/camera.h"

#include <gtest/gtest.h>

#include <vector>

namespace penumbra {
namespace {

TEST(Camera, FrameIsRightUpBackward) {
  Camera c;
  c.eye = {0, 0, 5};
  c.target = {0, 0, 0};
  Frame f = c.frame();
  EXPECT_NEAR(f.s.x, 1, 1e-6f);
  EXPECT_NEAR(f.t.y, 1, 1e-6f);
  EXPECT_NEAR(f.n.z, 1, 1e-6f);
}

TEST(Camera, RayDirectionsFollowImageConventions) {
  Camera c;
  c.eye = {0, 0, 5};
  c.target = {0, 0, 0};
  c.fov_y = 90;
  c.width = 200;
  c.height = 100;
  Vec3f centre = c.ray_direction(100, 50);
  EXPECT_NEAR(centre.z, -1, 1e-6f);
  // (0, 0) is the top-left corner: left (-x) and up (+y). With fov_y = 90 the top edge is
  // at 45 degrees; the aspect ratio 2 puts the left edge at x = -2 (per unit of depth).
  Vec3f tl = c.ray_direction(0, 0);
  EXPECT_NEAR(tl.x / -tl.z, -2, 1e-5f);
  EXPECT_NEAR(tl.y / -tl.z, 1, 1e-5f);
  Vec3f br = c.ray_direction(200, 100);
  EXPECT_NEAR(br.x / -br.z, 2, 1e-5f);
  EXPECT_NEAR(br.y / -br.z, -1, 1e-5f);  // y grows downward in the image
  EXPECT_NEAR(length(br), 1, 1e-6f);
}

TEST(Camera, VerticalViewStillHasAFrame) {
  Camera c;
  c.eye = {0, 5, 0};
  c.target = {0, 0, 0};  // up (0,1,0) is parallel to the view direction
  Frame f = c.frame();
  EXPECT_NEAR(length(f.s), 1, 1e-5f);
  EXPECT_NEAR(dot(f.s, f.n), 0, 1e-5f);
  EXPECT_NEAR(f.n.y, 1, 1e-6f);
}

TEST(Camera, RowOfDirectionsEqualsOneAtATime) {
  // The vectorised row (the camera pass's spp = 1 path) gives the very floats of
  // ray_direction at each pixel centre, for odd widths and off-axis cameras.
  Camera cam;
  cam.eye = {0.4f, 1.5f, 3.0f};
  cam.target = {0.0f, 0.4f, 0.0f};
  cam.up = {0, 1, 0};
  cam.fov_y = 37.0f;
  cam.width = 203;
  cam.height = 97;
  const CameraProjection projection(cam);
  std::vector<float> dx(cam.width), dy(cam.width), dz(cam.width);
  for (int y : {0, 13, 96}) {
    projection.row_directions(y + 0.5f, cam.width, dx.data(), dy.data(), dz.data());
    for (int x = 0; x < cam.width; ++x) {
      const Vec3f d = cam.ray_direction(x + 0.5f, y + 0.5f);
      EXPECT_EQ(dx[x], d.x) << x << "," << y;
      EXPECT_EQ(dy[x], d.y) << x << "," << y;
      EXPECT_EQ(dz[x], d.z) << x << "," << y;
    }
  }
}

}  // namespace
TEST(Camera, ResolutionsAreNOrWxHWithSidesUpTo16384) {
  int w = 0, h = 0;
  EXPECT_TRUE(parse_resolution("32", &w, &h));
  EXPECT_EQ(w, 32);
  EXPECT_EQ(h, 32);
  EXPECT_TRUE(parse_resolution("640x480", &w, &h));
  EXPECT_EQ(w, 640);
  EXPECT_EQ(h, 480);
  EXPECT_TRUE(parse_resolution("16384x1", &w, &h));
  for (const char* bad : {"", "0", "x", "10x", "x10", "16385", "2x16385", "99999999999", "-5", "5x-5", "5 x 5", "5X5", "1e3"})
    EXPECT_FALSE(parse_resolution(bad, &w, &h)) << bad;
  EXPECT_EQ(w, 16384);  // untouched by the refused ones
}

}  // namespace penumbra
