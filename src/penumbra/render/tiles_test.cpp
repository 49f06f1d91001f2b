// A frame rendered as tiles (RenderSettings::crop) reassembles into the whole frame's image
// bit for bit, for every method that says so (MethodInfo::tile_exact): a cluster can render
// one big frame as independent pixel windows.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadow/shadow_method.h"
#include "penumbra/testing/image_bits.h"
#include "penumbra/testing/test_scenes.h"
#include "penumbra/trace/ray_tracer.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

// A box and a semi-transparent quad over the ground under two rect lights, seen by a camera
// of uneven size with two jittered rays per pixel.
Scene tile_scene() {
  std::vector<SceneObject> occluders;
  occluders.push_back(testing::object(testing::box({-0.6f, 0.3f, -0.4f}, {0.1f, 0.8f, 0.3f})));
  occluders.push_back(testing::object(testing::quad_y(1.1f, 0.2f, 1.0f, -0.6f, 0.5f), Vec3f(0.6f), 0.4f));
  Scene s = testing::ground_scene(std::move(occluders), testing::rect_light_down({0, 2, 0}, 1.2f, 0.8f));
  s.lights.push_back(testing::rect_light_down({0.9f, 2.4f, 0.4f}, 0.6f, 0.5f, Vec3f(0.5f)));
  s.camera.width = 37;
  s.camera.height = 29;
  s.camera.samples_per_pixel = 2;
  return s;
}

// 3 x 2 uneven tiles of the 37 x 29 image, cut off multiples of 4 and 16 (the camera pass's
// ray groups, the methods' shading tiles).
std::vector<PixelWindow> uneven_tiles() {
  const int xs[] = {0, 13, 22, 37}, ys[] = {0, 11, 29};
  std::vector<PixelWindow> tiles;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 3; ++i) tiles.push_back({xs[i], ys[j], xs[i + 1], ys[j + 1]});
  return tiles;
}

using testing::same_bits;

// The first pixel (x, y) where a and b differ, for the failure message.
std::string first_difference(const Image& a, const Image& b) {
  if (a.width() != b.width() || a.height() != b.height()) return "sizes differ";
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x)
      for (int c = 0; c < a.channels(); ++c) {
        const float u = a.at(x, y, c), v = b.at(x, y, c);
        if (std::memcmp(&u, &v, sizeof(float)) != 0)
          return "pixel " + std::to_string(x) + "," + std::to_string(y) + ": " + std::to_string(a.at(x, y, c)) +
                 " vs " + std::to_string(b.at(x, y, c));
      }
  return "none";
}

void paste(const Image& tile, const PixelWindow& w, Image& into) {
  ASSERT_EQ(tile.width(), w.width());
  ASSERT_EQ(tile.height(), w.height());
  for (int y = 0; y < w.height(); ++y)
    for (int x = 0; x < w.width(); ++x)
      for (int c = 0; c < tile.channels(); ++c) into.at(w.x0 + x, w.y0 + y, c) = tile.at(x, y, c);
}

struct Assembled {
  Image color, visibility;
};

// The tiles rendered by one Renderer (set_crop between them: the light-space structures are
// built once), pasted into a whole image.
Assembled render_tiles(const Scene& scene, const RenderSettings& settings, const std::vector<PixelWindow>& tiles) {
  Assembled a{Image(scene.camera.width, scene.camera.height, 3, -1.0f),
              Image(scene.camera.width, scene.camera.height, 1, -1.0f)};
  Renderer renderer(scene, settings);
  for (const PixelWindow& w : tiles) {
    renderer.set_crop(w);
    const RenderResult r = renderer.render();
    EXPECT_EQ(r.window, w);
    paste(r.color, w, a.color);
    paste(r.visibility, w, a.visibility);
  }
  return a;
}

RenderSettings settings_for(const std::string& method) {
  RenderSettings s;
  s.method = method;
  s.light_samples = 16;
  s.seed = 11;
  return s;
}

TEST(Tiles, ACropsRaysAreTheWholeFramesRaysThere) {
  const Scene scene = tile_scene();
  const RayTracer tracer(scene);
  const ViewSamples whole = camera_pass(scene, tracer, 3);
  for (const PixelWindow& w : uneven_tiles()) {
    SCOPED_TRACE(w.to_string());
    const ViewSamples crop = camera_pass(scene, tracer, 3, w);
    EXPECT_EQ(crop.width, 37);
    EXPECT_EQ(crop.height, 29);
    EXPECT_EQ(crop.window, w);
    std::vector<ViewSample> expected;
    for (const ViewSample& s : whole.samples) {
      const int x = static_cast<int>(s.pixel % 37), y = static_cast<int>(s.pixel / 37);
      if (x >= w.x0 && x < w.x1 && y >= w.y0 && y < w.y1) expected.push_back(s);
    }
    ASSERT_EQ(crop.size(), expected.size());
    EXPECT_EQ(std::memcmp(crop.samples.data(), expected.data(), expected.size() * sizeof(ViewSample)), 0);
  }
  // Every ray's index within its pixel, each pixel's in order.
  for (size_t k = 1; k < whole.size(); ++k)
    if (whole.samples[k].pixel == whole.samples[k - 1].pixel) EXPECT_GT(whole.samples[k].sub, whole.samples[k - 1].sub);
  for (const ViewSample& s : whole.samples) EXPECT_LT(s.sub, 2u);
}

// For every method at its defaults: the 6 tiles pasted together are the whole frame, bit for
// bit, where the method is tile-exact. For the others, what holds instead (see each
// registration's tile_exact comment).
TEST(Tiles, EveryMethodsTilesReassembleIntoTheWholeFrame) {
  const Scene scene = tile_scene();
  const auto methods = MethodRegistry::all();
  ASSERT_GE(methods.size(), 13u);
  for (const MethodInfo* info : methods) {
    SCOPED_TRACE(info->name);
    const RenderSettings settings = settings_for(info->name);
    const RenderResult whole = render_scene(scene, settings);
    ASSERT_EQ(whole.color.width(), 37);
    ASSERT_EQ(whole.color.height(), 29);
    EXPECT_EQ(whole.window, (PixelWindow{0, 0, 37, 29}));
    const Assembled tiles = render_tiles(scene, settings, uneven_tiles());
    if (info->tile_exact) {
      EXPECT_TRUE(same_bits(tiles.visibility, whole.visibility))
          << "V: " << first_difference(tiles.visibility, whole.visibility);
      EXPECT_TRUE(same_bits(tiles.color, whole.color)) << "colour: " << first_difference(tiles.color, whole.color);
    } else {
      // The tiles differ where the method's light view (fitted to the tile's samples) or its
      // prediction from neighbouring pixels differs: a few pixels at shadow edges, V close.
      double diff = 0;
      for (size_t i = 0; i < whole.visibility.pixel_count(); ++i)
        diff += std::abs(tiles.visibility.data()[i] - whole.visibility.data()[i]);
      EXPECT_LT(diff / whole.visibility.pixel_count(), 0.02);
    }
    // Not the trivial image: the occluders cast a shadow in every method.
    float v_min = 1.0f;
    for (float v : whole.visibility.data()) v_min = std::min(v_min, v);
    EXPECT_LT(v_min, 0.5f);
  }
}

// coherent-rt predicts a point's light from the points before it in its tile (agrawala2000
// §5.2), so it is exact for crops whose edges lie on its tiles' (-p tile=8 here).
TEST(Tiles, CoherentRtIsExactForTileAlignedCrops) {
  const Scene scene = tile_scene();
  RenderSettings settings = settings_for("coherent-rt");
  settings.params = {"tile=8"};
  const RenderResult whole = render_scene(scene, settings);
  const int xs[] = {0, 8, 24, 37}, ys[] = {0, 16, 29};
  std::vector<PixelWindow> tiles;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 3; ++i) tiles.push_back({xs[i], ys[j], xs[i + 1], ys[j + 1]});
  const Assembled a = render_tiles(scene, settings, tiles);
  EXPECT_TRUE(same_bits(a.visibility, whole.visibility)) << first_difference(a.visibility, whole.visibility);
  EXPECT_TRUE(same_bits(a.color, whole.color)) << first_difference(a.color, whole.color);
}

// A crop of the whole image, and an empty one, are no crop, for every method.
TEST(Tiles, EmptyOrWholeImageCropIsNoCrop) {
  const Scene scene = tile_scene();
  for (const MethodInfo* info : MethodRegistry::all()) {
    SCOPED_TRACE(info->name);
    RenderSettings settings = settings_for(info->name);
    const RenderResult none = render_scene(scene, settings);
    for (const PixelWindow& w : {PixelWindow{0, 0, 37, 29}, PixelWindow{5, 7, 5, 20}}) {
      settings.crop = w;
      const RenderResult r = render_scene(scene, settings);
      EXPECT_EQ(r.window, (PixelWindow{0, 0, 37, 29}));
      EXPECT_TRUE(same_bits(r.visibility, none.visibility)) << w.to_string();
      EXPECT_TRUE(same_bits(r.color, none.color)) << w.to_string();
    }
  }
}

TEST(Tiles, CropOutsideTheImageIsAnErrorNamingIt) {
  const Scene scene = tile_scene();
  RenderSettings settings = settings_for("hard");
  for (const PixelWindow& w : {PixelWindow{0, 0, 38, 29}, PixelWindow{-1, 0, 10, 10}, PixelWindow{30, 20, 37, 30}}) {
    settings.crop = w;
    try {
      render_scene(scene, settings);
      ADD_FAILURE() << w.to_string() << " rendered";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()), "crop=" + w.to_string() + ": outside the 37x29 image");
    }
  }
  // The Renderer checks the crop against the camera of each render.
  settings.crop = {20, 10, 37, 29};
  Renderer renderer(scene, settings);
  EXPECT_EQ(renderer.render().visibility.width(), 17);
  Camera smaller = scene.camera;
  smaller.width = 32;
  renderer.set_camera(smaller);
  EXPECT_THROW(renderer.render(), Error);
}

TEST(Tiles, MemoryEstimateCountsTheCropsPixels) {
  const Scene scene = tile_scene();
  RenderSettings settings = settings_for("hard");
  const uint64_t whole = estimate_render_memory(scene, settings).view_bytes;
  settings.crop = {0, 0, 37, 1};
  const uint64_t row = estimate_render_memory(scene, settings).view_bytes;
  EXPECT_EQ(whole, row * 29);
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
