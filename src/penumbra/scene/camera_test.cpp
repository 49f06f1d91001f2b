#include "penumbra/scene/camera.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "penumbra/core/error.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

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
    projection.row_directions(y + 0.5f, 0, cam.width, dx.data(), dy.data(), dz.data());
    for (int x = 0; x < cam.width; ++x) {
      const Vec3f d = cam.ray_direction(x + 0.5f, y + 0.5f);
      EXPECT_EQ(dx[x], d.x) << x << "," << y;
      EXPECT_EQ(dy[x], d.y) << x << "," << y;
      EXPECT_EQ(dz[x], d.z) << x << "," << y;
    }
  }
  // A part of a row (a crop's): the same floats as the whole row's.
  const int x_begin = 57, count = 31;
  std::vector<float> px(count), py(count), pz(count);
  projection.row_directions(13.5f, x_begin, count, px.data(), py.data(), pz.data());
  for (int i = 0; i < count; ++i) {
    const Vec3f d = cam.ray_direction(x_begin + i + 0.5f, 13.5f);
    EXPECT_EQ(px[i], d.x) << i;
    EXPECT_EQ(py[i], d.y) << i;
    EXPECT_EQ(pz[i], d.z) << i;
  }
}

TEST(Camera, PixelWindowsAreFourIntegersWithXAndYGrowing) {
  PixelWindow w;
  EXPECT_TRUE(w.empty());
  EXPECT_TRUE(parse_pixel_window("3,4,17,9", &w));
  EXPECT_EQ(w, (PixelWindow{3, 4, 17, 9}));
  EXPECT_EQ(w.width(), 14);
  EXPECT_EQ(w.height(), 5);
  EXPECT_EQ(w.to_string(), "3,4,17,9");
  for (const char* bad : {"", "1,2,3", "1,2,3,4,5", "1,2,1,4", "1,4,3,4", "-1,0,3,4", "a,0,3,4", "0,0,3,", "0,,3,4",
                          "0,0,123456,4", " 0,0,3,4"})
    EXPECT_FALSE(parse_pixel_window(bad, &w)) << bad;
}

TEST(Camera, CropWindowIsTheWholeImageWhenEmptyAndMustLieInside) {
  Camera cam;
  cam.width = 40;
  cam.height = 30;
  EXPECT_EQ(crop_window(PixelWindow{}, cam), (PixelWindow{0, 0, 40, 30}));
  EXPECT_EQ(crop_window(PixelWindow{0, 0, 40, 30}, cam), (PixelWindow{0, 0, 40, 30}));
  EXPECT_EQ(crop_window(PixelWindow{5, 6, 7, 8}, cam), (PixelWindow{5, 6, 7, 8}));
  for (const PixelWindow& bad : {PixelWindow{0, 0, 41, 30}, PixelWindow{-1, 0, 10, 10}, PixelWindow{0, 20, 10, 31}}) {
    try {
      crop_window(bad, cam);
      ADD_FAILURE() << bad.to_string();
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()), "crop=" + bad.to_string() + ": outside the 40x30 image");
    }
  }
}

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

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
