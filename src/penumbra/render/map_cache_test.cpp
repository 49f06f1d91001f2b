// The map cache (render/map_cache.h, --map-cache): a second render with the same lights and
// geometry reads the light-space data back instead of preparing it, and its image equals the
// first bit for bit; whatever prepare() reads changes the key, the camera does not; a damaged
// entry is a miss and is written again; methods that store nothing never touch the folder.
#include "penumbra/render/map_cache.h"

#include <fstream>

#include <gtest/gtest.h>

#include "penumbra/core/testing.h"
#include "penumbra/render/renderer.h"
#include "penumbra/testing/image_bits.h"
#include "penumbra/testing/test_scenes.h"

namespace penumbra {
namespace {
namespace PENUMBRA_UNITY_ID {

using testing::same_bits;

Scene box_scene() {
  std::vector<SceneObject> occluders;
  occluders.push_back(testing::object(testing::box({-0.5f, 0.3f, -0.4f}, {0.2f, 0.8f, 0.3f})));
  Scene s = testing::ground_scene(std::move(occluders), testing::rect_light_down({0, 2, 0}, 1.0f, 0.8f), 32);
  s.lights.push_back(testing::rect_light_down({0.8f, 2.5f, 0.3f}, 0.6f, 0.6f, Vec3f(0.5f)));
  return s;
}

RenderSettings lam_settings(const std::filesystem::path& dir) {
  RenderSettings settings;
  settings.method = "lam";
  settings.light_samples = 16;
  settings.seed = 5;
  settings.params = {"resolution=64"};
  settings.map_cache = dir;
  return settings;
}

TEST(MapCache, SecondRenderReadsTheMapsAndEqualsTheFirstBitForBit) {
  test::TempDir dir("map-cache-hit");
  const Scene scene = box_scene();
  const RenderSettings settings = lam_settings(dir.path());
  const RenderResult first = render_scene(scene, settings);
  EXPECT_EQ(first.stats.prepare_count, 2u);
  EXPECT_EQ(first.map_cache["misses"], 2);
  EXPECT_EQ(first.map_cache["stored"], 2);
  EXPECT_EQ(first.map_cache["entries"], 2);
  EXPECT_GT(first.map_cache["entry_bytes"].get<uint64_t>(), 0u);

  // Another camera: the light-space maps do not depend on it.
  Scene moved_camera = scene;
  moved_camera.camera.eye = {1.0f, 3.5f, 1.5f};
  moved_camera.camera.up = {0, 1, 0};
  for (const Scene* s : std::initializer_list<const Scene*>{&scene, &moved_camera}) {
    const RenderResult cached = render_scene(*s, settings);
    EXPECT_EQ(cached.stats.prepare_count, 0u);
    EXPECT_EQ(cached.map_cache["hits"], 2);
    EXPECT_EQ(cached.map_cache["misses"], 0);
    EXPECT_DOUBLE_EQ(cached.map_cache["hit_rate"].get<double>(), 1.0);
    EXPECT_EQ(cached.map_cache["bytes_read"], first.map_cache["bytes_written"]);
    RenderSettings without = settings;
    without.map_cache.clear();
    const RenderResult fresh = render_scene(*s, without);
    EXPECT_TRUE(same_bits(cached.visibility, fresh.visibility));
    EXPECT_TRUE(same_bits(cached.color, fresh.color));
    // The LDI's figures are reported as if it had been built in this run.
    EXPECT_EQ(cached.stats.extra["ldi"], fresh.stats.extra["ldi"]);
  }
}

TEST(MapCache, KeyFollowsEverythingPrepareReadsButNotTheCamera) {
  const Scene scene = box_scene();
  const std::string geometry = MapCache::geometry_digest(scene);
  const nlohmann::json params = {{"resolution", 64}};
  ShadowContext ctx;
  ctx.scene = &scene;
  ctx.light = &scene.lights[0];
  ctx.seed = 1;
  ctx.light_samples = 16;
  const std::string key = MapCache::key(geometry, "lam", params, ctx);
  EXPECT_EQ(key.size(), 32u);
  EXPECT_EQ(key, MapCache::key(geometry, "lam", params, ctx));

  Scene camera_moved = scene;
  camera_moved.camera.eye = {2, 2, 2};
  EXPECT_EQ(MapCache::geometry_digest(camera_moved), geometry);

  Scene vertex_moved = scene;
  vertex_moved.objects[1].mesh.positions[3].y += 1e-6f;
  EXPECT_NE(MapCache::geometry_digest(vertex_moved), geometry);
  Scene opacity = scene;
  opacity.objects[1].material.opacity = 0.5f;
  EXPECT_NE(MapCache::geometry_digest(opacity), geometry);

  std::vector<std::string> keys = {key};
  ShadowContext c = ctx;
  c.seed = 2;
  keys.push_back(MapCache::key(geometry, "lam", params, c));
  c = ctx;
  c.light_samples = 17;
  keys.push_back(MapCache::key(geometry, "lam", params, c));
  c = ctx;
  c.light_index = 1;
  keys.push_back(MapCache::key(geometry, "lam", params, c));
  AreaLight light = scene.lights[0];
  light.center.x += 1e-6f;
  c = ctx;
  c.light = &light;
  keys.push_back(MapCache::key(geometry, "lam", params, c));
  light = scene.lights[0];
  light.size.y *= 2;
  keys.push_back(MapCache::key(geometry, "lam", params, c));
  keys.push_back(MapCache::key(geometry, "lam", {{"resolution", 65}}, ctx));
  keys.push_back(MapCache::key(geometry, "other", params, ctx));
  keys.push_back(MapCache::key(MapCache::geometry_digest(vertex_moved), "lam", params, ctx));
  for (size_t i = 0; i < keys.size(); ++i)
    for (size_t j = i + 1; j < keys.size(); ++j) EXPECT_NE(keys[i], keys[j]) << i << " " << j;
}

TEST(MapCache, DamagedEntriesAreMissesAndAreWrittenAgain) {
  test::TempDir dir("map-cache-damaged");
  Scene scene = box_scene();
  scene.lights.resize(1);
  const RenderSettings settings = lam_settings(dir.path());
  const RenderResult first = render_scene(scene, settings);
  std::filesystem::path entry;
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) entry = e.path();
  ASSERT_FALSE(entry.empty());
  const auto size = std::filesystem::file_size(entry);

  // A byte flipped in the middle (the record's digest no longer matches), then a truncated
  // file, then garbage: each is a miss, prepared afresh, written again whole.
  for (int damage = 0; damage < 3; ++damage) {
    SCOPED_TRACE(damage);
    // The entry as it is now: each pass writes it again, with its own timings' digits, so it
    // may be shorter than the first (truncating to the first's size less 7 then lengthened it
    // with zeros behind a whole record: a hit, under load, where the first render was slow).
    const auto size_now = std::filesystem::file_size(entry);
    if (damage == 0) {
      std::fstream f(entry, std::ios::in | std::ios::out | std::ios::binary);
      f.seekg(static_cast<std::streamoff>(size_now / 2));
      char c = 0;
      f.read(&c, 1);
      c = static_cast<char>(c ^ 0x20);
      f.seekp(static_cast<std::streamoff>(size_now / 2));
      f.write(&c, 1);
    } else if (damage == 1) {
      std::filesystem::resize_file(entry, size_now - 7);
    } else {
      std::ofstream(entry, std::ios::binary | std::ios::trunc) << "not a map";
    }
    const RenderResult again = render_scene(scene, settings);
    EXPECT_EQ(again.map_cache["misses"], 1);
    EXPECT_EQ(again.stats.prepare_count, 1u);
    EXPECT_TRUE(same_bits(again.visibility, first.visibility));
    EXPECT_EQ(again.map_cache["stored"], 1);
    // Written whole again (its size differs by the digits of the timings it records).
    EXPECT_NEAR(static_cast<double>(std::filesystem::file_size(entry)), static_cast<double>(size), 64.0);
  }
  const RenderResult hit = render_scene(scene, settings);
  EXPECT_EQ(hit.map_cache["hits"], 1);
  EXPECT_TRUE(same_bits(hit.visibility, first.visibility));
}

TEST(MapCache, MethodsThatStoreNothingLeaveTheFolderEmpty) {
  test::TempDir dir("map-cache-none");
  RenderSettings settings = lam_settings(dir.path());
  settings.params.clear();
  for (const char* method : {"reference", "hard", "shadow-map"}) {
    settings.method = method;
    const RenderResult r = render_scene(box_scene(), settings);
    EXPECT_EQ(r.map_cache["hits"], 0) << method;
    EXPECT_EQ(r.map_cache["misses"], 0) << method;
    EXPECT_EQ(r.map_cache["entries"], 0) << method;
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

TEST(MapCache, AFileInPlaceOfTheFolderIsAnErrorNamingIt) {
  test::TempDir dir("map-cache-file");
  const std::filesystem::path file = dir / "not-a-folder";
  std::ofstream(file) << "x";
  const std::string message = test::error_message([&] { render_scene(box_scene(), lam_settings(file)); });
  EXPECT_NE(message.find("--map-cache " + file.string() + ": exists and is not a folder"), std::string::npos)
      << message;
}

}  // namespace PENUMBRA_UNITY_ID
}  // namespace
}  // namespace penumbra
