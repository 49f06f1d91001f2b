#include "penumbra/scene/camera.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace penumbra
